// Bucket depth peeling's routing, shared by its passes (prepended to each stage).
// A pixel's depth range [nearest, farthest] (the bounds pass) is split into `buckets` equal
// parts over depth in fixed point with 31 fraction bits: exact integer arithmetic, so every
// pass, and the CPU twin (`bucket::select`), routes a depth to the same bucket. Bucket b keeps
// its nearest depth in slot 2b and its farthest in slot 2b + 1; slot s is channel s % 4 of
// layer s / 4 of the bucket targets.

struct BucketParams {
    buckets: u32,
    slots: u32,
    layers: u32,
    unused: u32,
}

// What the bounds and bucket targets are cleared to and what a fragment writes to the
// channels of other buckets: below every −z and z of a window depth, so MAX blending ignores it.
const NO_DEPTH: f32 = -2.0;
// Buckets fit the 32-bit claim word: two slots each.
const MAX_BUCKETS: u32 = 16u;

// Window depth in [0, 1] as fixed point: z · 2^31 is exact in f32, and the conversion truncates.
fn depth_fixed(z: f32) -> u32 {
    return u32(z * 2147483648.0);
}

// The bucket of depth `z` in a pixel whose fragments span [nearest, farthest].
fn bucket_of(z: f32, nearest: f32, farthest: f32, buckets: u32) -> u32 {
    let lo = depth_fixed(nearest);
    let hi = max(depth_fixed(farthest), lo);
    let width = (hi - lo) / buckets + 1u;
    return min((max(depth_fixed(z), lo) - lo) / width, buckets - 1u);
}
