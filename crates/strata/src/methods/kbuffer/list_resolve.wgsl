#define_import_path strata::kbuffer::list_resolve
#import strata::kbuffer::storage::{fragment_words, pixel_word, pixels}
#import strata::kbuffer::words::{SEEN}
#import strata::fragment::{Fragment, fragment_before}
#import strata::kbuffer::list::{HEAD, node_fragment, node_next, node_word, pool_nodes}
#import strata::steps::{step}

// Resolve access to the linked lists: sequential reads follow a cursor, so visiting a list in
// order costs one step per fragment. A pixel's list holds at most the fragments it saw, each in
// one node of the pool: walks stop after min(seen, pool) nodes, so no list a racing writer left
// malformed (a cycle through a stale link) can run on.

// The cursor belongs to one pixel: a read of another pixel starts from that pixel's head.
var<private> cursor_pixel: u32 = 0xffffffffu;
var<private> cursor_index: u32 = 0xffffffffu;
var<private> cursor_link: u32 = 0u;

fn stored_count(p: u32) -> u32 {
    var n = 0u;
    var at = atomicLoad(&pixels[pixel_word(p, HEAD)]);
    let limit = min(atomicLoad(&pixels[pixel_word(p, SEEN)]), pool_nodes());
    while at != 0u {
        if n >= limit || !step() {
            break;
        }
        n += 1u;
        at = node_next(at);
    }
    return n;
}

fn stored_fragment(p: u32, i: u32) -> Fragment {
    if p == cursor_pixel && i == cursor_index + 1u && cursor_index != 0xffffffffu {
        cursor_link = node_next(cursor_link);
    } else {
        cursor_link = atomicLoad(&pixels[pixel_word(p, HEAD)]);
        for (var j = 0u; j < i; j++) {
            if !step() {
                break;
            }
            cursor_link = node_next(cursor_link);
        }
    }
    cursor_pixel = p;
    cursor_index = i;
    return node_fragment(cursor_link);
}

// A node's sort key: its fragment's depth and tag (colors are not needed to order it).
fn node_key(link: u32) -> Fragment {
    let w = node_word(link);
    return Fragment(bitcast<f32>(atomicLoad(&fragment_words[w])), atomicLoad(&fragment_words[w + 1u]), 0u, 0u);
}

fn set_next(link: u32, next: u32) {
    atomicStore(&fragment_words[node_word(link) + 4u], next);
}

// Whether pixel p's list of n nodes is in (depth, tag) order: one walk, which ends at the
// first node out of order (false too where the adapter ended the walk early).
fn list_in_order(p: u32, n: u32) -> bool {
    var at = atomicLoad(&pixels[pixel_word(p, HEAD)]);
    if at == 0u {
        return true;
    }
    var previous = node_key(at);
    var i = 1u;
    for (; i < n; i++) {
        if !step() {
            break;
        }
        at = node_next(at);
        if at == 0u {
            return false;
        }
        let key = node_key(at);
        if fragment_before(key, previous) {
            return false;
        }
        previous = key;
    }
    return i == n;
}

// Sorts pixel p's list of n nodes (stored_count) in place by (depth, tag), stably, so that a
// resolve reads it in order: a bottom-up merge sort of the links, ⌈log₂ n⌉ passes that each
// merge neighbouring runs of `width` nodes, about 1.5·n steps a pass — O(n log n) where a
// k-depth sort takes O(n²/32) (a GPU display's watchdog and lavapipe's loop limit meet the
// latter first). Equal keys keep their list order, which is the order of their storage index.
// Only the resolve runs it, one invocation per pixel, after every capture: nothing races it.
// Returns false when a loop ended early (lavapipe's loop limit): the list is then not sorted.
fn sort_in_place(p: u32, n: u32) -> bool {
    cursor_index = 0xffffffffu;
    // A list already in order (each sample's resolve after its pixel's first, with --msaa; or
    // kb-ll's sorted insertion) needs one walk, not log n passes.
    if list_in_order(p, n) {
        return true;
    }
    var complete = true;
    var width = 1u;
    var merges = 0u;
    for (; merges < 32u; merges++) {
        if width >= n {
            break;
        }
        var rest = atomicLoad(&pixels[pixel_word(p, HEAD)]);
        var head = 0u;
        var tail = 0u;
        var visited = 0u;
        // Each round merges the run of `width` nodes at `rest` with the run after it.
        var round = 0u;
        for (; round < n; round++) {
            if rest == 0u || !step() {
                break;
            }
            if visited >= n {
                break;
            }
            var a = rest;
            var b = rest;
            var count_a = 0u;
            for (; count_a < width; count_a++) {
                if b == 0u || !step() {
                    break;
                }
                if visited + count_a >= n {
                    break;
                }
                b = node_next(b);
            }
            complete = complete && (count_a == width || b == 0u || visited + count_a == n);
            var count_b = min(width, n - visited - count_a);
            var steps = 0u;
            let total = count_a + count_b;
            for (; steps < total; steps++) {
                if !step() {
                    break;
                }
                var take_b = count_a == 0u;
                if count_a != 0u && count_b != 0u && b != 0u {
                    // Strictly before: equal keys keep the earlier run's node first.
                    take_b = fragment_before(node_key(b), node_key(a));
                }
                if take_b && b == 0u {
                    // The list ended inside the second run.
                    break;
                }
                var node = a;
                if take_b {
                    node = b;
                    b = node_next(b);
                    count_b -= 1u;
                } else {
                    a = node_next(a);
                    count_a -= 1u;
                }
                if tail == 0u {
                    head = node;
                } else {
                    set_next(tail, node);
                }
                tail = node;
                visited += 1u;
            }
            complete = complete && (steps == total || b == 0u);
            // `b` stopped on the node after the second run: the next round's first run.
            rest = b;
        }
        // Every pass takes all n nodes; one that took fewer was cut short.
        complete = complete && visited == n;
        if tail != 0u {
            // What this pass did not reach (only where it was cut short, or past n nodes) stays
            // linked behind it, so the list keeps every node.
            set_next(tail, rest);
            atomicStore(&pixels[pixel_word(p, HEAD)], head);
        }
        width *= 2u;
    }
    return complete && (width >= n || merges == 32u);
}
