#define_import_path strata::kbuffer::fixed_capture
#import strata::kbuffer::storage::{count_seen, kp, tail_add}
#import strata::fragment::{Fragment}
#import strata::kbuffer::slot_access::{store_slot}

// Fixed-array A-buffer capture (the FABS scheme): a per-pixel counter gives each fragment a slot
// of a fixed-size array (`stride` slots). Fragments past the array are counted, and blended into
// the tail with --tail blend. Used by `abuffer-fixed` (stride k) and `kb-ab-fixed` (stride sized
// from measured need, the k nearest selected in resolve).

// The capture step: a slot from the pixel's counter, or the tail.
fn capture_fixed(p: u32, f: Fragment) {
    let s = count_seen(p);
    if s < kp.stride {
        store_slot(p, s, f);
    } else {
        tail_add(p, f);
    }
}
