//! CPU twins of the k-buffer structures; each function mirrors the named WGSL function.
//!
//! - [`before`]: `fragment_before` (`shaders/shared/fragment.wgsl`) — depth, ties by tag.
//! - [`MaxArray`]: `array_insert` + `array_replace_max` (`kplus_capture.wgsl`), the farthest
//!   fragment in slot 0, the others unordered; [`MaxArray::culled`]: `culled`.
//! - [`MaxHeap`]: `heap_insert` (`kplus_capture.wgsl`), a binary max-heap in slot order.
//! - [`SortedArray`]: `sorted_insert` + `culled_sorted` (`kb_capture.wgsl`, `kb` / `kb-ps`).
//! - [`SemiHeap`]: `capture_semiheap` + `semiheap_insert` (`semiheap_capture.wgsl`), run one
//!   fragment at a time: H a max-heap of h slots, S the rest, unordered.
//! - [`sort_local`], [`k_depth_sort`]: the functions of the same names in `resolve.wgsl`.
//! - The MDT packings ([`mdt32_key`], [`mdt64_key`], [`mdt_pack_keys`] and their inverses,
//!   [`mdt_cascade`]): written here first as the specification the GPU code follows.
//!
//! Each insert returns the fragment that fell out of the structure (the one the GPU adds to the
//! tail), so that kept + fallen = inserted can be checked.

use crate::resolve::Fragment;
use crate::scene::{linear_to_srgb, srgb_to_linear};

/// `fragment_before`: `a` is composited before `b` — nearer, or as near with a smaller tag.
pub fn before(a: &Fragment, b: &Fragment) -> bool {
    a.depth < b.depth || (a.depth == b.depth && a.tag < b.tag)
}

/// The k+-buffer max-array: up to `k` fragments, the maximum (farthest by [`before`]) in slot 0
/// once there are two or more, the others in no particular order.
#[derive(Clone, Debug, PartialEq)]
pub struct MaxArray {
    pub k: usize,
    pub slots: Vec<Fragment>,
}

impl MaxArray {
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
    pub k: usize,
    pub slots: Vec<Fragment>,
}

impl MaxHeap {
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
    pub k: usize,
    pub h: usize,
    pub heap: MaxHeap,
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
    pub k: usize,
    pub slots: Vec<Fragment>,
}

impl SortedArray {
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
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::cmp::Ordering;

    fn order(a: &Fragment, b: &Fragment) -> Ordering {
        if before(a, b) {
            Ordering::Less
        } else if before(b, a) {
            Ordering::Greater
        } else {
            Ordering::Equal
        }
    }

    fn sorted(v: &[Fragment]) -> Vec<Fragment> {
        let mut v = v.to_vec();
        v.sort_by(order);
        v
    }

    /// Depths from {0.1, 0.2, 0.3} half the time, so that many are equal.
    fn depth() -> impl Strategy<Value = f32> {
        prop_oneof![prop::sample::select(vec![0.1f32, 0.2, 0.3]), 0.0f32..=1.0]
    }

    /// Fragments with distinct tags (primitive i, random facing) in random order.
    fn fragments(max: usize) -> impl Strategy<Value = Vec<Fragment>> {
        prop::collection::vec((depth(), any::<bool>(), any::<u32>(), any::<u32>()), 0..max)
            .prop_map(|v| {
                v.into_iter()
                    .enumerate()
                    .map(|(i, (depth, front, rg, ba))| Fragment {
                        depth,
                        tag: (i as u32) << 1 | front as u32,
                        rg,
                        ba,
                    })
                    .collect::<Vec<_>>()
            })
            .prop_shuffle()
    }

    trait Store: Clone + PartialEq + std::fmt::Debug {
        fn make(k: usize) -> Self;
        fn put(&mut self, f: Fragment) -> Option<Fragment>;
        fn cull(&self, f: &Fragment) -> bool;
        fn kept(&self) -> Vec<Fragment>;
        fn invariant(&self) -> bool;
    }

    impl Store for MaxArray {
        fn make(k: usize) -> Self {
            Self::new(k)
        }
        fn put(&mut self, f: Fragment) -> Option<Fragment> {
            self.insert(f)
        }
        fn cull(&self, f: &Fragment) -> bool {
            self.culled(f)
        }
        fn kept(&self) -> Vec<Fragment> {
            self.slots.clone()
        }
        fn invariant(&self) -> bool {
            self.slots.iter().all(|c| !before(&self.slots[0], c))
        }
    }

    impl Store for MaxHeap {
        fn make(k: usize) -> Self {
            Self::new(k)
        }
        fn put(&mut self, f: Fragment) -> Option<Fragment> {
            self.insert(f)
        }
        fn cull(&self, f: &Fragment) -> bool {
            self.culled(f)
        }
        fn kept(&self) -> Vec<Fragment> {
            self.slots.clone()
        }
        fn invariant(&self) -> bool {
            (1..self.slots.len()).all(|i| !before(&self.slots[(i - 1) / 2], &self.slots[i]))
        }
    }

    impl Store for SemiHeap {
        fn make(k: usize) -> Self {
            Self::new(k, 1)
        }
        fn put(&mut self, f: Fragment) -> Option<Fragment> {
            self.insert(f)
        }
        fn cull(&self, f: &Fragment) -> bool {
            self.culled(f)
        }
        fn kept(&self) -> Vec<Fragment> {
            SemiHeap::kept(self)
        }
        fn invariant(&self) -> bool {
            let heap = &self.heap.slots;
            let heap_ok = (1..heap.len()).all(|i| !before(&heap[(i - 1) / 2], &heap[i]));
            // A full H holds the h farthest: nothing in S is after H's least.
            let top_ok = !self.heap.is_full()
                || self.rest.iter().all(|r| heap.iter().all(|x| !before(x, r)));
            heap_ok && top_ok
        }
    }

    impl Store for SortedArray {
        fn make(k: usize) -> Self {
            Self::new(k)
        }
        fn put(&mut self, f: Fragment) -> Option<Fragment> {
            self.insert(f)
        }
        fn cull(&self, f: &Fragment) -> bool {
            self.culled(f)
        }
        fn kept(&self) -> Vec<Fragment> {
            self.slots.clone()
        }
        fn invariant(&self) -> bool {
            self.slots.windows(2).all(|w| before(&w[0], &w[1]))
        }
    }

    /// Inserts `frags` the way the capture shaders do (cull first when `culling`), checking the
    /// structure's invariant and the culling test at every step, then that it holds exactly the
    /// k nearest and that kept + fallen = inserted.
    fn check_store<S: Store>(
        k: usize,
        frags: &[Fragment],
        culling: bool,
    ) -> Result<(), TestCaseError> {
        check_store_with(S::make(k), k, frags, culling)
    }

    fn check_store_with<S: Store>(
        mut s: S,
        k: usize,
        frags: &[Fragment],
        culling: bool,
    ) -> Result<(), TestCaseError> {
        let mut fallen = Vec::new();
        for (step, f) in frags.iter().enumerate() {
            let is_culled = s.cull(f);
            if is_culled {
                // The culling test never rejects a fragment that belongs.
                let mut t = s.clone();
                prop_assert_eq!(t.put(*f), Some(*f), "culled fragment would enter");
                prop_assert_eq!(&t, &s);
            }
            if culling && is_culled {
                fallen.push(*f);
            } else {
                let before_len = s.kept().len();
                let out = s.put(*f);
                prop_assert_eq!(
                    out.is_none(),
                    before_len < k && s.kept().len() == before_len + 1
                );
                fallen.extend(out);
            }
            prop_assert!(s.kept().len() <= k);
            prop_assert!(
                s.invariant(),
                "invariant broken after insert {}: {:?}",
                step,
                s
            );
            // At every step the kept set is the k nearest so far.
            let so_far = sorted(&frags[..=step]);
            prop_assert_eq!(sorted(&s.kept()), so_far[..so_far.len().min(k)].to_vec());
        }
        let all = sorted(frags);
        prop_assert_eq!(sorted(&s.kept()), all[..all.len().min(k)].to_vec());
        let mut union = s.kept();
        union.extend(fallen);
        prop_assert_eq!(sorted(&union), all);
        Ok(())
    }

    fn tol_srgb(decoded_linear: f32, original_linear: f32) -> f32 {
        (linear_to_srgb(decoded_linear) - linear_to_srgb(clamp01(original_linear))).abs()
    }

    proptest! {
        #[test]
        fn max_array_keeps_k_nearest(k in 1usize..=24, frags in fragments(80), culling in any::<bool>()) {
            check_store::<MaxArray>(k, &frags, culling)?;
        }

        #[test]
        fn max_heap_keeps_k_nearest(k in 1usize..=24, frags in fragments(80), culling in any::<bool>()) {
            check_store::<MaxHeap>(k, &frags, culling)?;
        }

        #[test]
        fn semi_heap_keeps_k_nearest(
            k in 1usize..=24,
            h_pick in 0usize..24,
            frags in fragments(80),
            culling in any::<bool>(),
        ) {
            let h = 1 + h_pick % k;
            check_store_with(SemiHeap::new(k, h), k, &frags, culling)?;
        }

        #[test]
        fn sorted_array_keeps_k_nearest(k in 1usize..=24, frags in fragments(80), culling in any::<bool>()) {
            check_store::<SortedArray>(k, &frags, culling)?;
        }

        #[test]
        fn sort_local_sorts(frags in fragments(64)) {
            let mut v = frags.clone();
            sort_local(&mut v);
            prop_assert_eq!(v, sorted(&frags));
        }

        #[test]
        fn sort_local_sorts_equal_keys(
            keys in prop::collection::vec((depth(), 0u32..4, any::<u32>()), 0..64),
        ) {
            // Equal (depth, tag) pairs too: compare the keys only.
            let frags: Vec<Fragment> = keys
                .iter()
                .map(|&(depth, tag, rg)| Fragment { depth, tag, rg, ba: 0 })
                .collect();
            let mut v = frags.clone();
            sort_local(&mut v);
            let key = |v: &[Fragment]| v.iter().map(|f| (f.depth, f.tag)).collect::<Vec<_>>();
            prop_assert_eq!(key(&v), key(&sorted(&frags)));
            let mut rgs: Vec<u32> = v.iter().map(|f| f.rg).collect();
            let mut orig: Vec<u32> = frags.iter().map(|f| f.rg).collect();
            rgs.sort_unstable();
            orig.sort_unstable();
            prop_assert_eq!(rgs, orig);
        }

        #[test]
        fn k_depth_sort_selects_the_nearest(
            frags in fragments(200),
            limit in 0usize..=200,
            chunk in 1usize..40,
        ) {
            let all = sorted(&frags);
            let n = all.len();
            let first = limit.min(n);
            let (composited, tail) = k_depth_sort(&frags, limit, chunk);
            prop_assert_eq!(&composited, &all[..first].to_vec());
            // With the tail dropped nothing past `limit` is kept.
            prop_assert!(tail.is_empty());

            let (composited, tail) = k_depth_sort_with(&frags, limit, chunk, true);
            prop_assert_eq!(&composited, &all[..first].to_vec());
            prop_assert_eq!(&tail, &all[first..].to_vec());
        }

        /// Storages that keep no primitive (kb-mdt64, kb-mdt-pack) give exact duplicates: every
        /// one is still visited once, in order.
        #[test]
        fn k_depth_sort_keeps_exact_duplicates(
            depths in prop::collection::vec(0u8..4, 0..150),
            limit in 0usize..=150,
            chunk in 1usize..40,
        ) {
            let frags: Vec<Fragment> = depths
                .iter()
                .enumerate()
                .map(|(i, &d)| Fragment { depth: d as f32 * 0.1, tag: 0, rg: i as u32, ba: 0 })
                .collect();
            let (composited, tail) = k_depth_sort_with(&frags, limit, chunk, true);
            let all: Vec<_> = composited.iter().chain(&tail).collect();
            prop_assert_eq!(all.len(), frags.len());
            prop_assert!(all.windows(2).all(|w| w[0].depth <= w[1].depth));
            let mut seen: Vec<u32> = all.iter().map(|f| f.rg).collect();
            seen.sort_unstable();
            prop_assert_eq!(seen, (0..frags.len() as u32).collect::<Vec<_>>());
            prop_assert_eq!(composited.len(), limit.min(frags.len()));
        }

        #[test]
        fn k_depth_sort_chunk_32(frags in fragments(200), limit in 0usize..=200) {
            let all = sorted(&frags);
            let (composited, _) = k_depth_sort(&frags, limit, 32);
            prop_assert_eq!(composited, all[..limit.min(all.len())].to_vec());
        }

        #[test]
        fn mdt_cascade_keeps_k_nearest(
            k in 1usize..=24,
            depths in prop::collection::vec(depth(), 0..80),
        ) {
            let mut slots = vec![0u32; k];
            let mut slots64 = vec![0u64; k];
            let mut keys = Vec::new();
            let mut keys64 = Vec::new();
            for (i, &d) in depths.iter().enumerate() {
                let key = mdt32_key(d);
                let key64 = mdt64_key(d, [(i % 7) as f32 / 6.0, 0.5, 0.25, 1.0]);
                let expect = slots.iter().all(|&s| s != 0).then(|| *slots.iter().min().unwrap().min(&key));
                let expect64 = slots64.iter().all(|&s| s != 0).then(|| *slots64.iter().min().unwrap().min(&key64));
                prop_assert_eq!(mdt_cascade(&mut slots, key), expect);
                prop_assert_eq!(mdt_cascade64(&mut slots64, key64), expect64);
                keys.push(key);
                keys64.push(key64);
                let mut want = keys.clone();
                want.sort_unstable_by(|a, b| b.cmp(a));
                want.resize(k, 0);
                prop_assert_eq!(&slots, &want);
                let mut want64 = keys64.clone();
                want64.sort_unstable_by(|a, b| b.cmp(a));
                want64.resize(k, 0);
                prop_assert_eq!(&slots64, &want64);
            }
            // The slots are the k nearest depths, ascending.
            let mut near = depths.clone();
            near.sort_by(f32::total_cmp);
            near.truncate(k);
            let got: Vec<f32> = slots.iter().take_while(|&&s| s != 0).map(|&s| mdt32_depth(s)).collect();
            prop_assert_eq!(got, near);
        }

        #[test]
        fn mdt_cascade_random_keys(
            k in 1usize..=24,
            keys in prop::collection::vec(prop_oneof![1u32..=4, 1u32..=u32::MAX], 0..80),
        ) {
            let mut slots = vec![0u32; k];
            for (i, &key) in keys.iter().enumerate() {
                let full = slots.iter().all(|&s| s != 0);
                let expect = full.then(|| *slots.iter().min().unwrap().min(&key));
                prop_assert_eq!(mdt_cascade(&mut slots, key), expect);
                let mut want = keys[..=i].to_vec();
                want.sort_unstable_by(|a, b| b.cmp(a));
                want.resize(k, 0);
                prop_assert_eq!(&slots, &want);
            }
        }

        #[test]
        fn mdt32_reverses_order_and_round_trips(
            a in (0u32..=0x7F80_0000).prop_map(f32::from_bits),
            b in (0u32..=0x7F80_0000).prop_map(f32::from_bits),
        ) {
            prop_assert_ne!(mdt32_key(a), 0);
            prop_assert_eq!(mdt32_depth(mdt32_key(a)).to_bits(), a.to_bits());
            if a < b {
                prop_assert!(mdt32_key(a) > mdt32_key(b));
            }
        }

        #[test]
        fn mdt64_round_trips(
            d1 in 0.0f32..=1.0,
            d2 in depth(),
            c1 in prop::array::uniform4(-0.5f32..1.5),
            c2 in prop::array::uniform4(0.0f32..=1.0),
        ) {
            let key = mdt64_key(d1, c1);
            prop_assert_ne!(key, 0);
            let (d, c) = mdt64_unpack(key);
            prop_assert_eq!(d.to_bits(), d1.to_bits());
            for i in 0..3 {
                prop_assert!(tol_srgb(c[i], c1[i]) <= 0.5 / 255.0 + 1e-5, "channel {}: {:?} vs {:?}", i, c, c1);
            }
            prop_assert!((c[3] - clamp01(c1[3])).abs() <= 0.5 / 255.0 + 1e-6);
            prop_assert_eq!(mdt64_key(d, c), key, "re-encoding the decoded value is stable");
            if d1 < d2 {
                prop_assert!(mdt64_key(d1, c1) > mdt64_key(d2, c2));
            }
        }

        #[test]
        fn mdt_pack_round_trips(
            d1 in prop_oneof![Just(0.0f32), Just(1.0f32), 0.0f32..=1.0, depth()],
            d2 in prop_oneof![Just(1.0f32), 0.0f32..=1.0, depth()],
            c in prop::array::uniform4(prop_oneof![Just(1.0f32), -0.5f32..1.5]),
        ) {
            // Depth: within 2^-20 (see `unpack_depth20`).
            let top = pack_depth20(d1);
            prop_assert!(top <= 0xF_FFFF);
            let back = unpack_depth20(top);
            prop_assert!((back as f64 - d1 as f64).abs() <= (2.0f64).powi(-20), "{} -> {}", d1, back);
            // Monotone.
            if d1 < d2 {
                prop_assert!(pack_depth20(d1) <= pack_depth20(d2));
            }
            let (ia, ib) = mdt_pack_keys(d1, c);
            prop_assert_ne!(ia, 0);
            prop_assert_ne!(ib, 0);
            prop_assert_eq!(ia >> 12, ib >> 12, "a and b share the depth bits");
            prop_assert_eq!(!ia >> 12, top);
            let (d, rgba) = mdt_pack_unpack(ia, ib);
            prop_assert_eq!(d.to_bits(), back.to_bits());
            for i in 0..3 {
                prop_assert!(tol_srgb(rgba[i], c[i]) <= 1.0 / 63.0 + 1e-5, "channel {}: {:?} vs {:?}", i, rgba, c);
            }
            prop_assert!((rgba[3] - clamp01(c[3])).abs() <= 1.0 / 63.0 + 1e-6);
            // Nearer depth bits make larger inverted keys.
            let (ja, jb) = mdt_pack_keys(d2, c);
            if pack_depth20(d1) < pack_depth20(d2) {
                prop_assert!(ia > ja && ib > jb);
            }
        }
    }

    #[test]
    fn pack_depth20_bounds() {
        assert_eq!(pack_depth20(0.0), 0);
        assert_eq!(pack_depth20(-3.0), 0);
        assert_eq!(pack_depth20(f32::NAN), 0);
        assert_eq!(pack_depth20(1.0), 0xF_FFFF);
        assert_eq!(pack_depth20(7.0), 0xF_FFFF);
        assert_eq!(unpack_depth20(0), 0.0);
        assert_eq!(unpack_depth20(0xF_FFFF), 1.0 - (2.0f32).powi(-20));
        assert_eq!(BELOW_ONE, f32::from_bits(0x3F7F_FFFF));
        // The far plane with full colour stays below the empty key.
        let (a, b) = mdt_pack_keys(1.0, [1.0; 4]);
        assert_eq!((a, b), (1, 1));
    }

    #[test]
    fn zero_k_drops_everything() {
        let f = Fragment {
            depth: 0.5,
            tag: 2,
            rg: 0,
            ba: 0,
        };
        assert_eq!(MaxArray::new(0).insert(f), Some(f));
        assert_eq!(MaxHeap::new(0).insert(f), Some(f));
        assert_eq!(SortedArray::new(0).insert(f), Some(f));
        assert!(MaxArray::new(0).culled(&f));
    }
}
