// k-buffer family storage, shared by its capture and resolve stages.
// Keep `KParams` in sync with `KParams` in kbuffer/mod.rs.
//
// Binding 1 is the method's fragment storage (slots.wgsl for slot arrays, mdt.wgsl for keys).
// pixels: 4 words per pixel — seen (every fragment that reached the pixel), filled (slots in use),
// lock, and aux (a per-method flag). tail: 5 words per pixel of fixed-point sums for --tail blend.

struct KParams {
    k: u32,
    stride: u32,
    max_tries: u32,
    culling: u32,
    tail_blend: u32,
    // Fixed A-buffers keep no FILLED count: their stored count is min(seen, stride).
    count_by_seen: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> kp: KParams;
@group(1) @binding(2) var<storage, read_write> pixels: array<atomic<u32>>;
@group(1) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;
@group(1) @binding(4) var<storage, read_write> tail: array<atomic<u32>>;

const SEEN: u32 = 0u;
const FILLED: u32 = 1u;
const LOCK: u32 = 2u;
const AUX: u32 = 3u;

const COUNTER_LOCK_FAILURES: u32 = 0u;
const COUNTER_DROPPED: u32 = 1u;
const COUNTER_MAX_SEEN: u32 = 2u;
const COUNTER_ALLOCATED: u32 = 3u;
const COUNTER_LOST: u32 = 4u;
const COUNTER_SEEN_TOTAL: u32 = 5u;

// Fixed-point scale of the tail sums. A pixel's sums wrap past about a thousand bright tail
// fragments (colors are clamped at 64) or ten thousand nearly opaque ones.
const TAIL_SCALE: f32 = 65536.0;

fn pixel_word(p: u32, word: u32) -> u32 {
    return p * 4u + word;
}

// Blends a fragment beyond the k nearest into the pixel's unsorted tail (--tail blend).
fn tail_add(p: u32, f: Fragment) {
    if kp.tail_blend == 0u {
        return;
    }
    let c = fragment_color(f);
    let a = clamp(c.a, 0.0, 0.999);
    let w = p * 5u;
    atomicAdd(&tail[w], u32(a * clamp(c.r, 0.0, 64.0) * TAIL_SCALE));
    atomicAdd(&tail[w + 1u], u32(a * clamp(c.g, 0.0, 64.0) * TAIL_SCALE));
    atomicAdd(&tail[w + 2u], u32(a * clamp(c.b, 0.0, 64.0) * TAIL_SCALE));
    atomicAdd(&tail[w + 3u], u32(a * TAIL_SCALE));
    atomicAdd(&tail[w + 4u], u32(-log(1.0 - a) * TAIL_SCALE));
}

// Test-and-set on the pixel's lock word. Callers loop with a bounded number of tries and do the
// critical section inside the loop body, then break: a thread that fails keeps no lock, so lanes
// of one SIMD group make progress with or without independent thread scheduling.
fn try_lock(p: u32) -> bool {
    return atomicExchange(&pixels[pixel_word(p, LOCK)], 1u) == 0u;
}

fn unlock(p: u32) {
    atomicExchange(&pixels[pixel_word(p, LOCK)], 0u);
}

fn lock_failed(p: u32, f: Fragment) {
    atomicAdd(&counters[COUNTER_LOCK_FAILURES], 1u);
    tail_add(p, f);
}

// Counts the fragment at its pixel; returns how many came before it.
fn count_seen(p: u32) -> u32 {
    return atomicAdd(&pixels[pixel_word(p, SEEN)], 1u);
}
