#define_import_path strata::kbuffer::access
#import strata::fragment::Fragment

// A stage's access to the fragments its method stored, whatever the storage layout: the
// definition STORAGE_* picks the layout's accessors (each layout's *_resolve.wgsl, or mdt64.wgsl).

#ifdef STORAGE_SLOTS
#import strata::kbuffer::slots_resolve as layout
#else ifdef STORAGE_SEMIHEAP
#import strata::kbuffer::semiheap_resolve as layout
#else ifdef STORAGE_LIST
#import strata::kbuffer::list_resolve as layout
#else ifdef STORAGE_MDT32
#import strata::kbuffer::mdt32_resolve as layout
#else ifdef STORAGE_PACK
#import strata::kbuffer::pack_resolve as layout
#else ifdef STORAGE_MDT64
#import strata::kbuffer::mdt64 as layout
#else ifdef STORAGE_KEYS
#import strata::kbuffer::keys_resolve as layout
#else ifdef STORAGE_SBUFFER
#import strata::kbuffer::sbuffer_resolve as layout
#else ifdef STORAGE_KPLUS_SBUFFER
#import strata::kbuffer::kplus_sbuffer_resolve as layout
#endif

// Fragments stored at pixel `p` (at most the method's capacity).
fn stored_count(p: u32) -> u32 {
    return layout::stored_count(p);
}

// The i-th stored fragment of pixel `p`, in storage order (sorted only after `sort_stored`).
fn stored_fragment(p: u32, i: u32) -> Fragment {
    return layout::stored_fragment(p, i);
}

// Puts pixel p's n stored fragments in (depth, primitive) order in place where the layout can
// (a list relinks its nodes, slot arrays and the memory-aware k+-buffer's regions are heap
// sorted: O(n log n)); true when it did, so that storage order is then that order. Only a
// resolve calls it, after every capture.
fn sort_stored(p: u32, n: u32) -> bool {
#ifdef STORAGE_LIST
    return layout::sort_in_place(p, n);
#else ifdef STORAGE_SLOTS
    return layout::sort_in_place(p, n);
#else ifdef STORAGE_KPLUS_SBUFFER
    return layout::sort_in_place(p, n);
#else
    return false;
#endif
}
