//! CPU twins of the k-buffer structures; each function mirrors the named WGSL function.
//!
//! - [`before`]: `fragment_before` (`shaders/shared/fragment.wgsl`) — depth, ties by tag.
//! - [`MaxArray`]: `array_insert` + `array_replace_max` (`kplus_capture.wgsl`), the farthest
//!   fragment in slot 0, the others unordered; [`MaxArray::culled`]: `culled`.
//! - [`MaxHeap`]: `heap_insert` (`kplus_capture.wgsl`), a binary max-heap in slot order.
//! - [`SortedArray`]: `sorted_insert` + `culled_sorted` (`kb_capture.wgsl`, `kb` / `kb-ps`).
//! - [`mlab`]: `mlab_insert` + `merge_layers` (`kb_capture.wgsl`), in f64: the closed form of
//!   `mlab` for fragments arriving in a given order.
//! - [`SemiHeap`]: `capture_semiheap` + `semiheap_insert` (`semiheap_capture.wgsl`), run one
//!   fragment at a time: H a max-heap of h slots, S the rest, unordered.
//! - [`sort_local`], [`k_depth_sort`]: the functions of the same names in `resolve.wgsl`.
//! - The MDT packings ([`mdt32_key`], [`mdt64_key`], [`mdt_pack_keys`] and their inverses,
//!   [`mdt_cascade`]): written here first as the specification the GPU code follows.
//!
//! Each insert returns the fragment that fell out of the structure (the one the GPU adds to the
//! tail), so that kept + fallen = inserted can be checked.

use crate::resolve::{Fragment, RefFragment};
use crate::scene::{linear_to_srgb, srgb_to_linear};

/// `fragment_before`: `a` is composited before `b` — nearer, or as near with a smaller tag.
pub fn before(a: &Fragment, b: &Fragment) -> bool {
    a.depth < b.depth || (a.depth == b.depth && a.tag < b.tag)
}

/// `new(k)` and `is_full` of the caches of up to `k` fragments in `slots`.
macro_rules! k_slots {
    ($($cache:ident),*) => {$(
        impl $cache {
            /// An empty cache of up to `k` fragments.
            pub fn new(k: usize) -> Self {
                Self {
                    k,
                    slots: Vec::with_capacity(k),
                }
            }

            /// Whether all `k` slots are taken.
            pub fn is_full(&self) -> bool {
                self.slots.len() >= self.k
            }
        }
    )*};
}

k_slots!(MaxArray, MaxHeap, SortedArray);

/// The k+-buffer max-array: up to `k` fragments, the maximum (farthest by [`before`]) in slot 0
/// once there are two or more, the others in no particular order.
#[derive(Clone, Debug, PartialEq)]
pub struct MaxArray {
    /// Fragments kept at most.
    pub k: usize,
    /// The kept fragments.
    pub slots: Vec<Fragment>,
}

impl MaxArray {
    /// `culled`: `f` strictly behind the depth of a full array's maximum — it cannot enter.
    /// (Depth only: the GPU reads one word outside the lock; ties go through the lock.)
    pub fn culled(&self, f: &Fragment) -> bool {
        self.k == 0 || (self.is_full() && f.depth > self.slots[0].depth)
    }

    /// `array_insert`: returns the fragment that fell out — `f` itself when it is not before
    /// the maximum of a full array, else the evicted maximum; `None` while filling.
    pub fn insert(&mut self, f: Fragment) -> Option<Fragment> {
        if self.k == 0 {
            return Some(f);
        }
        let n = self.slots.len();
        if n < self.k {
            if n > 0 {
                let m = self.slots[0];
                if before(&m, &f) {
                    self.slots.push(m);
                    self.slots[0] = f;
                } else {
                    self.slots.push(f);
                }
            } else {
                self.slots.push(f);
            }
            return None;
        }
        let m = self.slots[0];
        if !before(&f, &m) {
            return Some(f);
        }
        self.replace_max(f);
        Some(m)
    }

    /// `array_replace_max`: puts `f` in place of the maximum of a full array and moves the new
    /// maximum to slot 0.
    fn replace_max(&mut self, f: Fragment) {
        let mut max_key = f;
        let mut max_i = 0;
        for (i, c) in self.slots.iter().enumerate().take(self.k).skip(1) {
            if before(&max_key, c) {
                max_key = *c;
                max_i = i;
            }
        }
        if max_i == 0 {
            self.slots[0] = f;
        } else {
            self.slots[0] = self.slots[max_i];
            self.slots[max_i] = f;
        }
    }
}

/// The k+-buffer max-heap: up to `k` fragments as a binary max-heap (children of slot i at
/// 2i + 1 and 2i + 2), the maximum at the root.
#[derive(Clone, Debug, PartialEq)]
pub struct MaxHeap {
    /// Fragments kept at most.
    pub k: usize,
    /// The heap's fragments.
    pub slots: Vec<Fragment>,
}

impl MaxHeap {
    /// `culled`: `f` strictly behind the depth of a full heap's root — it cannot enter.
    pub fn culled(&self, f: &Fragment) -> bool {
        self.k == 0 || (self.is_full() && f.depth > self.slots[0].depth)
    }

    /// `heap_sift_up` while filling, else `f` in place of the root (`heap_sift_down`) whatever
    /// their order; returns the old root when full.
    pub fn insert_or_replace_root(&mut self, f: Fragment) -> Option<Fragment> {
        if self.is_full() && self.k > 0 {
            let root = self.slots[0];
            self.sift_down(f);
            return Some(root);
        }
        self.insert(f)
    }

    /// `heap_sift_down` from the root of a full heap.
    fn sift_down(&mut self, f: Fragment) {
        let k = self.k;
        let mut i = 0;
        loop {
            let left = 2 * i + 1;
            if left >= k {
                break;
            }
            let mut child = left;
            let mut cf = self.slots[left];
            if left + 1 < k {
                let rf = self.slots[left + 1];
                if before(&cf, &rf) {
                    child = left + 1;
                    cf = rf;
                }
            }
            if !before(&f, &cf) {
                break;
            }
            self.slots[i] = cf;
            i = child;
        }
        self.slots[i] = f;
    }

    /// `heap_insert`: sift-up while filling; when full, `f` replaces the root and sifts down.
    /// Returns the fragment that fell out (`f`, or the old root), `None` while filling.
    pub fn insert(&mut self, f: Fragment) -> Option<Fragment> {
        if self.k == 0 {
            return Some(f);
        }
        let n = self.slots.len();
        if n < self.k {
            // The slot at n is written by the loop or the final store.
            self.slots.push(f);
            let mut i = n;
            while i > 0 {
                let parent = (i - 1) / 2;
                let pf = self.slots[parent];
                if !before(&pf, &f) {
                    break;
                }
                self.slots[i] = pf;
                i = parent;
            }
            self.slots[i] = f;
            return None;
        }
        let root = self.slots[0];
        if !before(&f, &root) {
            return Some(f);
        }
        self.sift_down(f);
        Some(root)
    }
}

/// The semi-heap k-buffer (`kplus-semiheap`): `heap`, a max-heap of up to `h` fragments (the h
/// farthest of those cached once the pixel is full), and `rest`, up to k − h fragments unordered.
#[derive(Clone, Debug, PartialEq)]
pub struct SemiHeap {
    /// Fragments kept at most.
    pub k: usize,
    /// Fragments the heap holds at most.
    pub h: usize,
    /// The h farthest.
    pub heap: MaxHeap,
    /// The others, unordered.
    pub rest: Vec<Fragment>,
}

impl SemiHeap {
    /// `h` in 1..=k.
    pub fn new(k: usize, h: usize) -> Self {
        assert!((1..=k).contains(&h), "heap size {h} outside 1..={k}");
        Self {
            k,
            h,
            heap: MaxHeap::new(h),
            rest: Vec::with_capacity(k - h),
        }
    }

    /// Whether the cache holds k fragments.
    pub fn is_full(&self) -> bool {
        self.heap.is_full() && self.rest.len() == self.k - self.h
    }

    /// `culled`: strictly behind the depth of a full cache's heap top.
    pub fn culled(&self, f: &Fragment) -> bool {
        self.is_full() && f.depth > self.heap.slots[0].depth
    }

    /// `capture_semiheap` without the lock (one fragment at a time): returns the fragment that
    /// fell out, `None` while filling.
    pub fn insert(&mut self, f: Fragment) -> Option<Fragment> {
        if self.rest.len() < self.k - self.h {
            self.rest.push(f);
            return None;
        }
        let mut fallen = None;
        if self.heap.is_full() {
            let root = self.heap.slots[0];
            if !before(&f, &root) {
                return Some(f);
            }
            fallen = Some(root);
        }
        // b: the farthest of S and f; f takes b's place.
        let farthest = (0..self.rest.len()).fold(None::<usize>, |best, i| match best {
            Some(j) if !before(&self.rest[j], &self.rest[i]) => Some(j),
            _ => Some(i),
        });
        let b = match farthest {
            Some(j) if before(&f, &self.rest[j]) => std::mem::replace(&mut self.rest[j], f),
            _ => f,
        };
        // Filling H sifts b up; a full H takes b in place of the evicted root.
        let out = self.heap.insert_or_replace_root(b);
        debug_assert_eq!(out.is_some(), fallen.is_some());
        fallen
    }

    /// Every cached fragment.
    pub fn kept(&self) -> Vec<Fragment> {
        self.heap.slots.iter().chain(&self.rest).copied().collect()
    }
}

/// The k-buffer with sorted insertion (`kb`, `kb-ps`): up to `k` fragments in [`before`] order.
#[derive(Clone, Debug, PartialEq)]
pub struct SortedArray {
    /// Fragments kept at most.
    pub k: usize,
    /// The kept fragments, nearest first.
    pub slots: Vec<Fragment>,
}

impl SortedArray {
    /// `culled_sorted`: `f` strictly behind the depth of a full array's last fragment.
    pub fn culled(&self, f: &Fragment) -> bool {
        self.k == 0 || (self.is_full() && f.depth > self.slots[self.k - 1].depth)
    }

    /// `sorted_insert`: shifts the fragments after `f` back by one; when full the last falls
    /// out (or `f` itself when it is not before the last). `None` while filling.
    pub fn insert(&mut self, f: Fragment) -> Option<Fragment> {
        if self.k == 0 {
            return Some(f);
        }
        let n = self.slots.len();
        let mut i = n;
        let mut fallen = None;
        if n >= self.k {
            let last = self.slots[self.k - 1];
            if !before(&f, &last) {
                return Some(f);
            }
            fallen = Some(last);
            i = self.k - 1;
        } else {
            // The new slot n is written by the loop or the final store.
            self.slots.push(f);
        }
        while i > 0 {
            let prev = self.slots[i - 1];
            if !before(&f, &prev) {
                break;
            }
            self.slots[i] = prev;
            i -= 1;
        }
        self.slots[i] = f;
        fallen
    }
}

/// `mlab_insert` over fragments arriving in `arrivals`' order: the pixel's layers, nearest first
/// — at most `k`, the two farthest merged by [`merge_layers`] whenever a fragment makes k + 1.
pub fn mlab(arrivals: &[RefFragment], k: usize) -> Vec<RefFragment> {
    let mut layers: Vec<RefFragment> = Vec::with_capacity(k + 1);
    for f in arrivals {
        let at = layers.partition_point(|l| RefFragment::order(l, f).is_lt());
        layers.insert(at, *f);
        if layers.len() > k {
            let back = layers.pop().expect("k + 1 layers");
            let front = layers.pop().expect("k ≥ 1 layers");
            layers.push(merge_layers(&front, &back));
        }
    }
    layers
}

/// `merge_layers`: `front` then `back` as one layer with `front`'s key, their joint opacity and
/// the straight color whose premultiplied value is theirs together.
pub fn merge_layers(front: &RefFragment, back: &RefFragment) -> RefFragment {
    let alpha = front.alpha + (1.0 - front.alpha) * back.alpha;
    let color = if alpha > 0.0 {
        [0, 1, 2].map(|c| {
            (front.alpha * front.color[c] + (1.0 - front.alpha) * back.alpha * back.color[c])
                / alpha
        })
    } else {
        [0.0; 3]
    };
    RefFragment {
        color,
        alpha,
        ..*front
    }
}

/// `sort_local`: insertion sort for up to 16 fragments, above that a bitonic network over the
/// list padded to 32 or 64 with fragments after every real one (at most 64, the shader's local
/// array).
pub fn sort_local(a: &mut [Fragment]) {
    let n = a.len();
    if n <= 16 {
        for i in 1..n {
            let f = a[i];
            let mut j = i;
            while j > 0 && before(&f, &a[j - 1]) {
                a[j] = a[j - 1];
                j -= 1;
            }
            a[j] = f;
        }
        return;
    }
    assert!(n <= 64, "sort_local sorts at most 64 fragments");
    let size = if n > 32 { 64 } else { 32 };
    let padding = Fragment {
        depth: f32::INFINITY,
        tag: u32::MAX,
        ..*a.first().expect("n > 16")
    };
    let mut v = a.to_vec();
    v.resize(size, padding);
    let mut k = 2;
    while k <= size {
        let mut j = k / 2;
        while j > 0 {
            for i in 0..size {
                let l = i ^ j;
                if l > i {
                    let ascending = i & k == 0;
                    let swap = if ascending {
                        before(&v[l], &v[i])
                    } else {
                        before(&v[i], &v[l])
                    };
                    if swap {
                        v.swap(i, l);
                    }
                }
            }
            j /= 2;
        }
        k *= 2;
    }
    a.copy_from_slice(&v[..n]);
}

/// `ordered_before`: [`before`], exact duplicates by their storage index.
fn ordered_before(a: (&Fragment, usize), b: (&Fragment, usize)) -> bool {
    before(a.0, b.0) || (!before(b.0, a.0) && a.1 < b.1)
}

/// `k_depth_sort` with `tail_blend` off (the resolve's default): returns the first `limit`
/// fragments of `stored` in [`before`] order (composited) and an empty tail.
///
/// The selection is the GPU's: chunks of `chunk` nearest fragments after the bound picked with a
/// max-array over (fragment, storage index), sorted with [`sort_local`]; the bound is the
/// largest (fragment, index) of the previous chunk, so exact duplicates are all visited; the loop
/// ends on an empty chunk, on a chunk shorter than `chunk`, or once `limit` fragments are
/// composited. Panics when `chunk` is 0.
pub fn k_depth_sort(
    stored: &[Fragment],
    limit: usize,
    chunk: usize,
) -> (Vec<Fragment>, Vec<Fragment>) {
    k_depth_sort_with(stored, limit, chunk, false)
}

/// `k_depth_sort` with the `tail_blend` switch: with it on, the selection continues past
/// `limit` and the second vector holds every stored fragment after the composited ones, in
/// order.
pub fn k_depth_sort_with(
    stored: &[Fragment],
    limit: usize,
    chunk: usize,
    tail_blend: bool,
) -> (Vec<Fragment>, Vec<Fragment>) {
    assert!(chunk > 0, "k_depth_sort: chunk must be at least 1");
    let mut composited = Vec::with_capacity(limit.min(stored.len()));
    let mut tail = Vec::new();
    let mut sel: Vec<(Fragment, usize)> = Vec::with_capacity(chunk.min(stored.len()));
    let mut bound: Option<(Fragment, usize)> = None;
    loop {
        sel.clear();
        for (i, f) in stored.iter().enumerate() {
            if let Some((b, bi)) = &bound {
                if !ordered_before((b, *bi), (f, i)) {
                    continue;
                }
            }
            if sel.len() < chunk {
                if !sel.is_empty() && ordered_before((&sel[0].0, sel[0].1), (f, i)) {
                    let m = sel[0];
                    sel.push(m);
                    sel[0] = (*f, i);
                } else {
                    sel.push((*f, i));
                }
            } else if ordered_before((f, i), (&sel[0].0, sel[0].1)) {
                sel[0] = (*f, i);
                let mut max_i = 0;
                for j in 1..sel.len() {
                    if ordered_before((&sel[max_i].0, sel[max_i].1), (&sel[j].0, sel[j].1)) {
                        max_i = j;
                    }
                }
                sel.swap(0, max_i);
            }
        }
        let m = sel.len();
        if m == 0 {
            break;
        }
        bound = Some(sel[0]);
        let mut frags: Vec<Fragment> = sel.iter().map(|s| s.0).collect();
        sort_local(&mut frags);
        for f in frags {
            if composited.len() < limit {
                composited.push(f);
            } else if tail_blend {
                tail.push(f);
            }
        }
        if m < chunk || (composited.len() >= limit && !tail_blend) {
            break;
        }
    }
    (composited, tail)
}

/// The mdt32 key of a depth: its bits inverted, so that an `atomicMax` cascade keeps the
/// nearest. Order-reversing over non-negative depths, and never 0 (the empty slot) for them.
pub fn mdt32_key(depth: f32) -> u32 {
    0xFFFF_FFFF - depth.to_bits()
}

/// The depth of an mdt32 key (inverse of [`mdt32_key`]).
pub fn mdt32_depth(key: u32) -> f32 {
    f32::from_bits(0xFFFF_FFFF - key)
}

fn cascade<T: Copy + Ord + Default>(slots: &mut [T], mut key: T) -> Option<T> {
    let empty = T::default();
    for slot in slots.iter_mut() {
        let old = *slot;
        *slot = old.max(key);
        if old == empty {
            return None;
        }
        key = old.min(key);
    }
    Some(key)
}

/// The `atomicMax` cascade over one pixel's slots (0 = empty): each slot keeps the larger of
/// itself and the carried key and passes the smaller on; stops at the first empty slot
/// (`None`), else returns the key displaced past the last slot. Slots filled only this way stay
/// in descending order (the nearest depths, ascending).
pub fn mdt_cascade(slots: &mut [u32], key: u32) -> Option<u32> {
    cascade(slots, key)
}

/// [`mdt_cascade`] over 64-bit keys ([`mdt64_key`]).
pub fn mdt_cascade64(slots: &mut [u64], key: u64) -> Option<u64> {
    cascade(slots, key)
}

fn clamp01(x: f32) -> f32 {
    // NaN goes to 0 (as WGSL's max/min would take it).
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// A linear channel as 8-bit sRGB: round(linear_to_srgb(clamp01(x)) · 255).
pub fn srgb8(linear: f32) -> u32 {
    (linear_to_srgb(clamp01(linear)) * 255.0).round() as u32
}

/// The linear value of an 8-bit sRGB channel (inverse of [`srgb8`] up to its rounding).
pub fn srgb8_to_linear(v: u32) -> f32 {
    srgb_to_linear(v as f32 / 255.0)
}

/// The mdt64 key: the mdt32 key of the depth in the high word; in the low word sRGB red,
/// green, blue in bytes 0–2 and linear alpha in byte 3.
pub fn mdt64_key(depth: f32, rgba: [f32; 4]) -> u64 {
    let [r, g, b, a] = rgba;
    let alpha = (clamp01(a) * 255.0).round() as u32;
    let color = srgb8(r) | srgb8(g) << 8 | srgb8(b) << 16 | alpha << 24;
    (mdt32_key(depth) as u64) << 32 | color as u64
}

/// Depth and linear RGBA of an mdt64 key (inverse of [`mdt64_key`]).
pub fn mdt64_unpack(key: u64) -> (f32, [f32; 4]) {
    let depth = mdt32_depth((key >> 32) as u32);
    let c = key as u32;
    let byte = |i: u32| (c >> (8 * i)) & 0xFF;
    (
        depth,
        [
            srgb8_to_linear(byte(0)),
            srgb8_to_linear(byte(1)),
            srgb8_to_linear(byte(2)),
            byte(3) as f32 / 255.0,
        ],
    )
}

/// The largest f32 below 1.
const BELOW_ONE: f32 = 0.999_999_94;

/// The top 20 bits of a depth in [0, 1]: the mantissa of d' = 0.5 + 0.5·depth (kept below 1,
/// so the exponent is that of [0.5, 1)), its low 3 bits dropped. Monotone in depth; depths
/// outside [0, 1] (and NaN, as 0) are clamped.
pub fn pack_depth20(depth: f32) -> u32 {
    let d = (0.5 + 0.5 * clamp01(depth)).min(BELOW_ONE);
    (d.to_bits() & 0x7F_FFFF) >> 3
}

/// The depth of 20 packed bits (inverse of [`pack_depth20`] up to its quantization): the
/// result differs from the packed depth in [0, 1] by at most 2⁻²⁰ — d' is rounded to f32 in
/// [0.5, 1) (ulp 2⁻²⁴; half an ulp, or one ulp where it is clamped below 1) and then loses 3
/// mantissa bits (under 8 ulp), under 2⁻²¹ in d', doubled back to depth.
pub fn unpack_depth20(top20: u32) -> f32 {
    let d = f32::from_bits(0x3F00_0000 | (top20 & 0xF_FFFF) << 3);
    (d - 0.5) * 2.0
}

fn srgb6(linear: f32) -> u32 {
    (linear_to_srgb(clamp01(linear)) * 63.0).round() as u32
}

const PACK_MAX_KEY: u32 = 0xFFFF_FFFE;

/// The two mdt-pack keys of a fragment, inverted for the `atomicMax` cascades:
/// a = depth20 << 12 | r6 << 6 | g6, b = depth20 << 12 | b6 << 6 | a6 (6-bit sRGB colour,
/// 6-bit linear alpha), each kept at most 0xFFFF_FFFE so the inverted key is never 0 (empty).
pub fn mdt_pack_keys(depth: f32, rgba: [f32; 4]) -> (u32, u32) {
    let [r, g, b, a] = rgba;
    let top = pack_depth20(depth) << 12;
    let a6 = (clamp01(a) * 63.0).round() as u32;
    let key_a = (top | srgb6(r) << 6 | srgb6(g)).min(PACK_MAX_KEY);
    let key_b = (top | srgb6(b) << 6 | a6).min(PACK_MAX_KEY);
    (0xFFFF_FFFF - key_a, 0xFFFF_FFFF - key_b)
}

/// Depth (from a's top 20 bits) and linear RGBA of a fragment's two inverted mdt-pack keys
/// (inverse of [`mdt_pack_keys`] up to its quantization).
pub fn mdt_pack_unpack(inv_a: u32, inv_b: u32) -> (f32, [f32; 4]) {
    let key_a = 0xFFFF_FFFF - inv_a;
    let key_b = 0xFFFF_FFFF - inv_b;
    let six = |k: u32, shift: u32| ((k >> shift) & 63) as f32 / 63.0;
    (
        unpack_depth20(key_a >> 12),
        [
            srgb_to_linear(six(key_a, 6)),
            srgb_to_linear(six(key_a, 0)),
            srgb_to_linear(six(key_b, 6)),
            six(key_b, 0),
        ],
    )
}

#[cfg(test)]
mod tests;
