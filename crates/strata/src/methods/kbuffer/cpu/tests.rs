use super::*;
use proptest::prelude::*;
use std::cmp::Ordering;

use crate::testing::fragment;

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

/// `Store` for a structure of the CPU twins: `make` builds one for k, `kept` lists its
/// fragments, `invariant` checks its shape; insertion and culling are its own.
macro_rules! store {
    ($t:ty, |$k:ident| $make:expr, |$s:ident| $kept:expr, |$i:ident| $invariant:expr) => {
        impl Store for $t {
            fn make($k: usize) -> Self {
                $make
            }
            fn put(&mut self, f: Fragment) -> Option<Fragment> {
                self.insert(f)
            }
            fn cull(&self, f: &Fragment) -> bool {
                self.culled(f)
            }
            fn kept(&self) -> Vec<Fragment> {
                let $s = self;
                $kept
            }
            fn invariant(&self) -> bool {
                let $i = self;
                $invariant
            }
        }
    };
}

store!(MaxArray, |k| Self::new(k), |s| s.slots.clone(), |s| {
    s.slots.iter().all(|c| !before(&s.slots[0], c))
});

store!(MaxHeap, |k| Self::new(k), |s| s.slots.clone(), |s| {
    (1..s.slots.len()).all(|i| !before(&s.slots[(i - 1) / 2], &s.slots[i]))
});

store!(SemiHeap, |k| Self::new(k, 1), |s| SemiHeap::kept(s), |s| {
    let heap = &s.heap.slots;
    let heap_ok = (1..heap.len()).all(|i| !before(&heap[(i - 1) / 2], &heap[i]));
    // A full H holds the h farthest: nothing in S is after H's least.
    let top_ok = !s.heap.is_full() || s.rest.iter().all(|r| heap.iter().all(|x| !before(x, r)));
    heap_ok && top_ok
});

store!(SortedArray, |k| Self::new(k), |s| s.slots.clone(), |s| {
    s.slots.windows(2).all(|w| before(&w[0], &w[1]))
});

/// Inserts `frags` the way the capture shaders do (cull first when `culling`), checking the
/// structure's invariant and the culling test at every step, then that it holds exactly the
/// k nearest and that kept + fallen = inserted.
fn check_store<S: Store>(k: usize, frags: &[Fragment], culling: bool) -> Result<(), TestCaseError> {
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

/// Layers with distinct primitives in a random arrival order: depths from a few values (ties
/// broken by primitive), opacities in (0, 1), colors in [0, 1].
fn layers(
    count: impl Into<prop::collection::SizeRange>,
) -> impl Strategy<Value = Vec<RefFragment>> {
    let layer = (
        prop::sample::select(vec![0.1f64, 0.2, 0.3, 0.4]),
        0.01f64..0.99,
        [0.0f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0],
    );
    prop::collection::vec(layer, count)
        .prop_map(|v| {
            v.into_iter()
                .enumerate()
                .map(|(i, (depth, alpha, color))| fragment(i as u32, depth, alpha, color))
                .collect::<Vec<_>>()
        })
        .prop_shuffle()
}

fn by_order(v: &[RefFragment]) -> Vec<RefFragment> {
    let mut v = v.to_vec();
    v.sort_by(RefFragment::order);
    v
}

fn composited(layers: &[RefFragment]) -> [f64; 3] {
    crate::resolve::composite(layers, [0.0; 3], false)
}

fn transmittance(layers: &[RefFragment]) -> f64 {
    layers.iter().map(|l| 1.0 - l.alpha).product()
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
}

proptest! {
    /// Up to k fragments mlab keeps them all, in order: the A-buffer's picture.
    #[test]
    fn mlab_is_exact_up_to_k_fragments(arrivals in layers(1..9), k in 8usize..12) {
        prop_assert_eq!(mlab(&arrivals, k), by_order(&arrivals));
    }

    /// Whatever the arrival order: at most k layers in order, the nearest fragment alone in
    /// front (k ≥ 2), and the pixel's total opacity exact (merges keep the product of
    /// transmittances).
    #[test]
    fn mlab_keeps_order_front_and_opacity(arrivals in layers(1..24), k in 1usize..9) {
        let kept = mlab(&arrivals, k);
        prop_assert_eq!(kept.len(), arrivals.len().min(k));
        prop_assert!(kept.windows(2).all(|w| RefFragment::order(&w[0], &w[1]).is_lt()));
        if k >= 2 {
            prop_assert_eq!(kept[0], by_order(&arrivals)[0]);
        }
        prop_assert!((transmittance(&kept) - transmittance(&arrivals)).abs() < 1e-12);
    }

    /// One fragment past k: a single merge, of the two farthest, whatever the order — the k − 1
    /// nearest exact and the picture the reference's (compositing the merged pair equals
    /// compositing both).
    #[test]
    fn mlab_one_past_k_merges_the_two_farthest(
        (k, arrivals) in (1usize..9).prop_flat_map(|k| (Just(k), layers(k + 1)))
    ) {
        let all = by_order(&arrivals);
        let kept = mlab(&arrivals, k);
        prop_assert_eq!(&kept[..k - 1], &all[..k - 1]);
        prop_assert!(close(composited(&kept), composited(&all)));
    }
}

/// Past k + 1 the merges depend on the arrival order. k = 1, three fragments a, b, c front to
/// back: arriving in depth order every merge puts the newcomer behind all before it (exact);
/// arriving a, c, b, b lands behind the merged a-c layer although it lies between them.
#[test]
fn mlab_merges_depend_on_arrival_order() {
    let f = |prim: u32, depth: f64, color: [f64; 3]| fragment(prim, depth, 0.5, color);
    let (a, b, c) = (
        f(0, 0.1, [1.0, 0.0, 0.0]),
        f(1, 0.2, [0.0, 1.0, 0.0]),
        f(2, 0.3, [0.0, 0.0, 1.0]),
    );
    let exact = composited(&[a, b, c]);
    assert!(close(composited(&mlab(&[a, b, c], 1)), exact));
    let out_of_order = mlab(&[a, c, b], 1);
    // a over c over b: green behind blue.
    let expected = [0.5, 0.125, 0.25];
    assert!(
        close(composited(&out_of_order), expected),
        "{:?}",
        composited(&out_of_order)
    );
    assert!((transmittance(&out_of_order) - 0.125).abs() < 1e-12);
}
