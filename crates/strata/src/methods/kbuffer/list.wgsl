#define_import_path strata::kbuffer::list
#import strata::kbuffer::counters::{COUNTER_ALLOCATED, COUNTER_LOST, COUNTER_OVERFLOWED}
#import strata::kbuffer::storage::{count_seen, counter_add, counters, fragment_words, kp, pixel_word, pixels, spend_tries, tail_add, try_budget}
#import strata::fragment::{Fragment, fragment_before}

// Per-pixel linked lists for the k-buffer family: nodes of 5 atomic words (depth bits, tag, rg,
// ba, next) in one pool; a pixel's HEAD word (pixels[.., FILLED]) and every `next` hold node
// index + 1, 0 ending the list. counters[COUNTER_ALLOCATED] hands out nodes; once it reaches the
// pool's size no fragment increments it again (it can pass the size only by the fragments in
// flight at that moment, so it never wraps and no node is handed out twice), and the fragments
// that found the pool full are counted in COUNTER_OVERFLOWED: the frame knows what it needed.
// Every walk is bounded by the pool's size.
// abuffer-ll, kb-ab-ll: the A-buffer's unsorted push, the k nearest (abuffer-ll: all) selected in
//   resolve.
// kb-ll: sorted insertion — walk to the fragment's place, link it with a compare-exchange on the
//   predecessor's link, walk on from the predecessor when another fragment got there first;
//   when the invocation's tries (`try_budget`) are spent the fragment is lost and counted. A
//   place beyond the k-th node means the fragment is not among the k nearest: it is culled
//   without taking a node.

const HEAD: u32 = 1u;

fn node_word(link: u32) -> u32 {
    return (link - 1u) * 5u;
}

fn node_fragment(link: u32) -> Fragment {
    let w = node_word(link);
    return Fragment(bitcast<f32>(atomicLoad(&fragment_words[w])), atomicLoad(&fragment_words[w + 1u]), atomicLoad(&fragment_words[w + 2u]), atomicLoad(&fragment_words[w + 3u]));
}

fn node_next(link: u32) -> u32 {
    return atomicLoad(&fragment_words[node_word(link) + 4u]);
}

// kb-ll's ordered link words (gpu::ordered): a walk acquires each link it follows, so the node
// it reaches reads as its inserter wrote it; an insertion releases its node's fields and `next`
// with the compare-exchange that links it.
fn acquire_head(p: u32) -> u32 {
    return atomicLoad(&pixels[pixel_word(p, HEAD)]);
}

fn acquire_next(link: u32) -> u32 {
    return atomicLoad(&fragment_words[node_word(link) + 4u]);
}

fn release_link_head(p: u32, expected: u32, link: u32) -> bool {
    return atomicCompareExchangeWeak(&pixels[pixel_word(p, HEAD)], expected, link).exchanged;
}

fn release_link_after(prev: u32, expected: u32, link: u32) -> bool {
    return atomicCompareExchangeWeak(&fragment_words[node_word(prev) + 4u], expected, link).exchanged;
}

fn pool_nodes() -> u32 {
    return arrayLength(&fragment_words) / 5u;
}

// Takes a node and writes the fragment into it; 0 when the pool is full (counted).
fn new_node(f: Fragment) -> u32 {
    if atomicLoad(&counters[COUNTER_ALLOCATED]) >= pool_nodes() {
        counter_add(COUNTER_OVERFLOWED, 1u);
        return 0u;
    }
    let node = atomicAdd(&counters[COUNTER_ALLOCATED], 1u);
    if node >= pool_nodes() {
        counter_add(COUNTER_OVERFLOWED, 1u);
        return 0u;
    }
    let w = node * 5u;
    atomicStore(&fragment_words[w], bitcast<u32>(f.depth));
    atomicStore(&fragment_words[w + 1u], f.tag);
    atomicStore(&fragment_words[w + 2u], f.rg);
    atomicStore(&fragment_words[w + 3u], f.ba);
    return node + 1u;
}

// The A-buffer's capture step: any fragment shader with these bindings can call it.
fn capture_list(p: u32, f: Fragment) {
    count_seen(p);
    let link = new_node(f);
    if link == 0u {
        return;
    }
    atomicStore(&fragment_words[node_word(link) + 4u], atomicExchange(&pixels[pixel_word(p, HEAD)], link));
}

// kb-ll's capture step. A failed exchange resumes the walk from `prev`, not from the head:
// nodes are never unlinked, so `prev` is still a predecessor of f and every node inserted since
// lies after it. The walk then takes at most k steps in all plus one re-read per try, where a
// restart from the head took up to k per try (docs/watchdog.md, C1). `position` undercounts the
// nodes linked before `prev` meanwhile, so a fragment may take a node past the k-th: the resolve
// selects the k nearest of every node it finds, so such a node costs pool, not exactness.
fn capture_sorted_list(p: u32, f: Fragment) {
    count_seen(p);
    var link = 0u;
    // `prev` is the predecessor's link (0: the head); `cur` the first node not yet passed.
    var prev = 0u;
    var cur = acquire_head(p);
    var position = 0u;
    let budget = try_budget();
    var t = 0u;
    for (; t < budget; t++) {
        // Walk on to the first node not before f.
        while cur != 0u {
            if position >= kp.k {
                break;
            }
            if !fragment_before(node_fragment(cur), f) {
                break;
            }
            prev = cur;
            cur = acquire_next(cur);
            position += 1u;
        }
        if position >= kp.k {
            // A node taken before a lost exchange stays unlinked: it is pool this frame used,
            // so it counts in the measured need that sizes the next frame's pool.
            spend_tries(t);
            tail_add(p, f);
            return;
        }
        if link == 0u {
            link = new_node(f);
            if link == 0u {
                spend_tries(t);
                return;
            }
        }
        atomicStore(&fragment_words[node_word(link) + 4u], cur);
        var swapped = false;
        if prev == 0u {
            swapped = release_link_head(p, cur, link);
        } else {
            swapped = release_link_after(prev, cur, link);
        }
        if swapped {
            spend_tries(t);
            return;
        }
        // Another fragment linked after `prev` first: read its link again.
        if prev == 0u {
            cur = acquire_head(p);
        } else {
            cur = acquire_next(prev);
        }
    }
    spend_tries(t);
    counter_add(COUNTER_LOST, 1u);
    tail_add(p, f);
}
