#define_import_path strata::kbuffer::list_resolve
#import strata::kbuffer::storage::{pixel_word, pixels}
#import strata::kbuffer::words::{SEEN}
#import strata::fragment::{Fragment}
#import strata::kbuffer::list::{HEAD, node_fragment, node_next, pool_nodes}

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
    while at != 0u && n < limit {
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
            cursor_link = node_next(cursor_link);
        }
    }
    cursor_pixel = p;
    cursor_index = i;
    return node_fragment(cursor_link);
}
