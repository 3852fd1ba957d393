#define_import_path strata::kbuffer::storage
#import strata::color::{Resolved}
#import strata::fragment::{Fragment, stored_color}
#import strata::kbuffer::counters::{COUNTER_LOCK_FAILURES}
#import strata::kbuffer::words::{BOUND, LOCK, PIXEL_WORDS, SEEN, TAIL_WORDS}
#import strata::kbuffer::params::{KParams}
#import strata::kbuffer::temporal::{culling_interface, note_outside}
#import strata::tail::{TailParams, tail_share_of}

// k-buffer family storage, shared by its capture and resolve stages.
// Keep the COUNTER_ indices in sync with `Counters` in kbuffer/mod.rs.
//
// Binding 1 is the method's fragment storage (`fragment_words` or `fragment_keys`, below).
// pixels: 4 words per pixel — seen (every fragment that reached the pixel), filled (slots in
// use; a list's head), lock, and bound (the culling bound: the farthest kept depth of a full
// pixel, as depth bits + 1; 0 while the pixel is not full). tail: 5 sums of 2 words (64-bit
// fixed point) per pixel for --tail blend. Every per-pixel word is cleared before
// each frame; slots and nodes are read only where this frame's writers published them.

@group(#{KBUFFER_GROUP}) @binding(0) var<uniform> kp: KParams;
// The fragment storage: 64-bit keys where the layout cascades them (KEYS64: keys.wgsl,
// mdt64.wgsl), else 32-bit words — slot records (slots.wgsl, kplus_sbuffer.wgsl), list nodes
// (list.wgsl) or 32-bit keys (mdt.wgsl); each layout's module says what its words hold.
#ifdef COHERENT
@group(#{KBUFFER_GROUP}) @binding(2) @coherent var<storage, read_write> pixels: array<atomic<u32>>;
#ifdef KEYS64
@group(#{KBUFFER_GROUP}) @binding(1) @coherent var<storage, read_write> fragment_keys: array<atomic<u64>>;
#else
@group(#{KBUFFER_GROUP}) @binding(1) @coherent var<storage, read_write> fragment_words: array<atomic<u32>>;
#endif
#else
@group(#{KBUFFER_GROUP}) @binding(2) var<storage, read_write> pixels: array<atomic<u32>>;
#ifdef KEYS64
@group(#{KBUFFER_GROUP}) @binding(1) var<storage, read_write> fragment_keys: array<atomic<u64>>;
#else
@group(#{KBUFFER_GROUP}) @binding(1) var<storage, read_write> fragment_words: array<atomic<u32>>;
#endif
#endif
@group(#{KBUFFER_GROUP}) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;
@group(#{KBUFFER_GROUP}) @binding(4) var<storage, read_write> tail: array<atomic<u32>>;
// The resolved pixels (the resolve's output; k-depth peeling's running composite).
@group(#{KBUFFER_GROUP}) @binding(5) var<storage, read_write> output: array<Resolved>;



// KParams::storage_layout (StorageLayout::index): each pixel's items together (0, pixel-major),
// or item i of every storage pixel together (1, slot-major).
const LAYOUT_SLOT_MAJOR: u32 = 1u;

// Pixels with storage of their own: with per-sample storage each sample is one (`sample_pixel`).
fn storage_pixels() -> u32 {
    return kp.pixels * kp.sample_slots;
}

// Where item i of storage pixel p's `per_pixel` items lies in a per-pixel array (its words,
// slots, keys or tail sums), in the frame's layout (--storage-layout). Pixel-major keeps a
// pixel's walk over its slots in a few cache lines (a CPU adapter runs it faster); slot-major
// puts item i of the neighbouring pixels that a GPU shades in one warp side by side, so the
// warp's access is a few memory transactions where pixel-major takes one per pixel. The CPU
// twin is `StorageLayout::item`.
fn pixel_item(p: u32, i: u32, per_pixel: u32) -> u32 {
    if kp.storage_layout == LAYOUT_SLOT_MAJOR {
        return i * storage_pixels() + p;
    }
    return p * per_pixel + i;
}

fn pixel_word(p: u32, word: u32) -> u32 {
    return pixel_item(p, word, PIXEL_WORDS);
}

// The pixel index of a fragment position, from the k-buffer's own width (no scene bindings).
fn kpixel(position: vec4<f32>) -> u32 {
    return u32(position.y) * kp.width + u32(position.x);
}

// The pixel index of `pixel`, from the k-buffer's own width.
fn kpixel_index(pixel: vec2<u32>) -> u32 {
    return pixel.y * kp.width + pixel.x;
}

// Storage pixels per pixel: `kp.sample_slots` in a stage composed with MULTISAMPLED (--msaa),
// else the constant 1, so that a single-sampled stage's loops over samples compile away. A
// software rasterizer (lavapipe) runs a loop's body at least once under its lanes' masks, nested
// loops and all: the single-sampled captures ran up to 1.8x slower there with the loop in.
fn storage_slots() -> u32 {
#ifdef MULTISAMPLED
    return kp.sample_slots;
#else
    return 1u;
#endif
}

// Depth bits a second pass's depth may differ by from the first's before it counts as farther.
// The hardware rasterizer gives a fragment the same depth in every pass (`position` is
// @invariant), which no specification quite promises: the margin keeps a kept fragment whose
// depth came out an ulp or two farther from missing its slot (among coplanar layers the tag
// decides, so a pixel's k-th kept key can lie at the fragment's own depth).
const DEPTH_MARGIN_ULPS: u32 = 4u;

// True when window depth `depth` lies more than DEPTH_MARGIN_ULPS behind the depth whose bits
// are `kept` (in a second pass of the key cascades: a fragment behind a full pixel's farthest
// kept key, or kpeel's nearest kept key behind a fragment). Depths are ≥ 0, whose bits order as
// the floats do, and at most 1 (no overflow).
fn clearly_behind(depth: f32, kept: u32) -> bool {
    return bitcast<u32>(depth) > kept + DEPTH_MARGIN_ULPS;
}

// Sample `s`'s storage pixel of pixel `p` (per-sample storage).
fn sample_pixel(p: u32, s: u32) -> u32 {
    return p * storage_slots() + s;
}

// Per-sample storage: the word after the sample pixels' words that counts pixel `p`'s
// fragments (each once, whatever it covers), as the statistics count them.
fn pixel_fragments_word(p: u32) -> u32 {
    return storage_pixels() * PIXEL_WORDS + p;
}

// The samples whose storage a fragment covering `mask` enters: bit s for `sample_pixel(p, s)`;
// without per-sample storage bit 0 alone, the pixel's own. None for an empty mask: a helper
// invocation (derivatives) covers no sample, and its atomics return undefined values, so it
// must never reach a lock or a link loop.
fn storage_samples(mask: u32) -> u32 {
    if mask == 0u {
        return 0u;
    }
    if storage_slots() <= 1u {
        return 1u;
    }
    return mask & ((1u << storage_slots()) - 1u);
}

// Counts a fragment once at its pixel for the statistics, where per-sample storage counts it
// in each sample it enters.
fn count_pixel_fragment(p: u32) {
    if storage_slots() > 1u {
        atomicAdd(&pixels[pixel_fragments_word(p)], 1u);
    }
}

// Adds n to the 64-bit counter at words (at, at + 1), carrying out of the low word.
fn counter_add(at: u32, n: u32) {
    let old = atomicAdd(&counters[at], n);
    if old > 0xffffffffu - n {
        atomicAdd(&counters[at + 1u], 1u);
    }
}

// The frame's tail parameters, from the k-buffer's uniforms.
fn kbuffer_tail() -> TailParams {
    return TailParams(kp.tail_blend, kp.tail_weight, kp.tail_depth_p, kp.tail_depth_q);
}

// One fragment's share of its pixel's tail sums (`tail_share_of`): the same share whichever way
// the fragment reaches the tail — evicted from a slot or culled at capture (`tail_add`), or left
// past k in the resolve (resolve.wgsl's local tail) — so a pixel's tail cannot depend on the
// order its fragments arrived in.
fn tail_share(f: Fragment) -> array<vec2<u32>, 5> {
    return tail_share_of(kbuffer_tail(), f);
}

// Word `word` of pixel p's tail sums (sum i: low word 2i, high word 2i + 1).
fn tail_word(p: u32, word: u32) -> u32 {
    return pixel_item(p, word, TAIL_WORDS);
}

// Blends a fragment beyond the k nearest into the pixel's unsorted tail (--tail blend|weighted), and
// notes it for temporal culling's interface (temporal.wgsl): every fragment the cache does not
// keep passes here.
fn tail_add(p: u32, f: Fragment) {
    note_outside(p, f.depth);
    if kp.tail_blend == 0u {
        return;
    }
    let share = tail_share(f);
    for (var i = 0u; i < 5u; i++) {
        let old = atomicAdd(&tail[tail_word(p, 2u * i)], share[i].x);
        let carry = select(0u, 1u, old > 0xffffffffu - share[i].x);
        if share[i].y + carry != 0u {
            atomicAdd(&tail[tail_word(p, 2u * i + 1u)], share[i].y + carry);
        }
    }
}

// Ordered accesses. Where the adapter takes SPIR-V passthrough (gpu::ordered), the atomics of
// functions named acquire_* and release_* get that ordering on storage memory; every other atomic
// stays relaxed. Only these words order others: the lock (its holder's slot accesses), the count
// that publishes lock-free slot stores to a lock holder, and a list's links.

// Takes the pixel's lock word: acquires the previous holder's writes.
fn acquire_lock(word: u32) -> bool {
    return atomicExchange(&pixels[word], 1u) == 0u;
}

// Drops the lock: releases this holder's writes to the next.
fn release_lock(word: u32) {
    atomicStore(&pixels[word], 0u);
}

// Adds n to a per-pixel word that publishes the stores before it; returns the old value.
fn release_published(word: u32, n: u32) -> u32 {
    return atomicAdd(&pixels[word], n);
}

// Reads a per-pixel word that publishes stores: what it counts is visible after it.
fn acquire_published(word: u32) -> u32 {
    return atomicLoad(&pixels[word]);
}

// Test-and-test-and-set on the pixel's lock word, one try. Callers loop with a bounded number
// of tries, do the critical section inside the `if` that took the lock, and leave the loop only
// by its condition: lanes of a SIMD group that failed wait at the `if`'s merge while the winner
// works. A try that sees the lock held fails on a relaxed load, without the exchange's write:
// spinners leave the cache line (shared by a pixel's sample words with --msaa, and slot-major
// by the lock words of its neighbours) to the holder.
fn try_lock(p: u32) -> bool {
    let word = pixel_word(p, LOCK);
    return atomicLoad(&pixels[word]) == 0u && acquire_lock(word);
}

fn unlock(p: u32) {
    release_lock(pixel_word(p, LOCK));
}

// The tries an invocation may still spend on locks and exchanges. A fragment shader runs one
// fragment an invocation; the compute rasterizer runs up to 64 an item, and several items an
// invocation, so `max_tries` bounds the invocation's tries in all, not each fragment's
// (docs/watchdog.md, C2): a spin that fails long enough to reach a display watchdog fails once,
// not once per fragment. Once they are spent, each later fragment still gets one try.
var<private> tries_spent: u32 = 0u;

fn try_budget() -> u32 {
    return max(kp.max_tries - min(tries_spent, kp.max_tries), 1u);
}

// `tries` is at most try_budget(): the sum stays below 2 max_tries + 2^12 fragments, no wrap.
fn spend_tries(tries: u32) {
    tries_spent += tries;
}

fn lock_failed(p: u32, f: Fragment) {
    counter_add(COUNTER_LOCK_FAILURES, 1u);
    tail_add(p, f);
}

// Counts the fragment at its pixel; returns how many came before it.
fn count_seen(p: u32) -> u32 {
    return atomicAdd(&pixels[pixel_word(p, SEEN)], 1u);
}

// Publishes the farthest kept depth of a full pixel (lock held). Once a pixel is full this only
// decreases, so a reader outside the lock that sees any published bound never culls what the
// test inside the lock would keep.
fn publish_bound(p: u32, farthest: f32) {
    atomicStore(&pixels[pixel_word(p, BOUND)], bitcast<u32>(farthest) + 1u);
}

// True when `f` is strictly behind the published bound of a full pixel: it cannot enter. Ties
// go through the lock, whose test also orders by primitive. One word: it cannot tear, and it was
// cleared before the frame, so no reader sees last frame's bound.
fn culled(p: u32, f: Fragment) -> bool {
    if kp.culling == 0u {
        return false;
    }
    let bound = atomicLoad(&pixels[pixel_word(p, BOUND)]);
    return bound != 0u && f.depth > bitcast<f32>(bound - 1u);
}

// Counts a fragment temporal culling rejected.
fn count_temporal_cull() {
    let at = kp.pixels;
    let old = atomicAdd(&culling_interface[at], 1u);
    if old == 0xffffffffu {
        atomicAdd(&culling_interface[at + 1u], 1u);
    }
}
