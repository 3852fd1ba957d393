use std::cmp::Reverse;
use std::collections::{BTreeSet, BinaryHeap};

use glam::Vec2;
use proptest::prelude::*;

use super::*;

fn convex_hull(mut points: Vec<Vec2>) -> Vec<Vec2> {
    let mut hull = Vec::new();
    convex_hull_into(&mut points, &mut hull);
    hull
}

fn monotone_chain(mut points: Vec<Vec2>) -> Vec<Vec2> {
    let mut hull = Vec::new();
    monotone_chain_into(&mut points, &mut hull);
    hull
}

/// Passes with each pass's nodes in order (the order within a pass is arbitrary).
fn sorted(passes: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
    passes
        .into_iter()
        .map(|mut pass| {
            pass.sort();
            pass
        })
        .collect()
}

#[test]
fn passes_follow_the_edges_and_a_cycle_takes_the_nearest_node() {
    // 0 → 1 → 2 and 3 alone: 3 shares the first pass; each edge starts a later pass.
    let graph = Graph::new(4, &[(0, 1), (1, 2)]);
    let (passes, cycles) = graph.passes(&[0, 1, 2, 3], |n| n as f32);
    assert_eq!(sorted(passes), vec![vec![0, 3], vec![1], vec![2]]);
    assert_eq!(cycles, 0);
    // 0 ⇄ 1: one cycle, broken at the nearer node, which then comes first.
    let distances = [-1.0f32, -2.0];
    let graph = Graph::new(2, &[(0, 1), (1, 0)]);
    let (passes, cycles) = graph.passes(&[0, 1], |n| distances[n as usize]);
    assert_eq!(passes, vec![vec![1], vec![0]]);
    assert_eq!(cycles, 1);
}

#[test]
fn a_cycle_is_broken_at_the_nearest_node_at_signed_distances() {
    // 3 → 0 and the cycle 0 → 1 → 2 → 0: the cycle opens at 1, the nearest (an
    // orthographic view's distances are signed), which shares 3's pass and heads the
    // cycle's.
    let distances = [0.5f32, -3.0, -1.0, 9.0];
    let graph = Graph::new(4, &[(0, 1), (1, 2), (2, 0), (3, 0)]);
    let (passes, cycles) = graph.passes(&[0, 1, 2, 3], |n| distances[n as usize]);
    assert_eq!(sorted(passes), vec![vec![1, 3], vec![2], vec![0]]);
    assert_eq!(cycles, 1);
}

/// The sort as it was, taking the nearest ready node first from a heap: the passes must not
/// depend on that order.
fn passes_nearest_first(
    graph: &Graph,
    nodes: &[u32],
    distance: &[f32],
) -> (Vec<BTreeSet<u32>>, u32) {
    let mut indegree: Vec<u32> = graph
        .state
        .iter()
        .map(|d| d.load(Ordering::Relaxed))
        .collect();
    let key = |g: u32| (Reverse(ordered_bits(distance[g as usize])), Reverse(g));
    let mut ready: BinaryHeap<_> = nodes
        .iter()
        .filter(|&&g| indegree[g as usize] == 0)
        .map(|&g| key(g))
        .collect();
    let mut by_distance = nodes.to_vec();
    by_distance.sort_by(|&a, &b| {
        distance[a as usize]
            .total_cmp(&distance[b as usize])
            .then(a.cmp(&b))
    });
    let mut pass_of = vec![u32::MAX; indegree.len()];
    let (mut passes, mut cycles, mut placed) = (Vec::<BTreeSet<u32>>::new(), 0, 0);
    while placed < nodes.len() {
        let g = match ready.pop() {
            Some((_, Reverse(g))) => g,
            None => {
                cycles += 1;
                *by_distance
                    .iter()
                    .find(|&&g| pass_of[g as usize] == u32::MAX)
                    .unwrap()
            }
        };
        if pass_of[g as usize] != u32::MAX {
            continue;
        }
        let pass = graph
            .neighbours(g)
            .filter(|(o, _)| pass_of[*o as usize] != u32::MAX)
            .map(|(o, _)| pass_of[o as usize] + 1)
            .max()
            .unwrap_or(0);
        pass_of[g as usize] = pass;
        if passes.len() <= pass as usize {
            passes.resize(pass as usize + 1, BTreeSet::new());
        }
        passes[pass as usize].insert(g);
        placed += 1;
        for (o, after) in graph.neighbours(g) {
            if after && pass_of[o as usize] == u32::MAX {
                indegree[o as usize] -= 1;
                if indegree[o as usize] == 0 {
                    ready.push(key(o));
                }
            }
        }
    }
    (passes, cycles)
}

proptest! {
    /// Random graphs with cycles (edges both ways, self-contained groups of nodes) and signed
    /// distances: the level-by-level sort, serial or parallel, gives the same passes and
    /// cycle count as taking the nearest ready node first.
    #[test]
    fn passes_do_not_depend_on_which_ready_node_goes_first(
        distances in proptest::collection::vec(-50.0f32..50.0, 1..60),
        edges in proptest::collection::vec((0usize..60, 0usize..60), 0..150),
    ) {
        let n = distances.len();
        let edges: Vec<(u32, u32)> = edges
            .into_iter()
            .map(|(a, b)| ((a % n) as u32, (b % n) as u32))
            .filter(|(a, b)| a != b)
            .collect();
        let nodes: Vec<u32> = (0..n as u32).collect();
        let expected = passes_nearest_first(&Graph::new(n, &edges), &nodes, &distances);
        // One thread per level and every level in parallel.
        for parallel_from in [usize::MAX, 0] {
            let (passes, cycles) = Graph::new(n, &edges).passes_in_levels(
                &nodes,
                |g| distances[g as usize],
                parallel_from,
            );
            let passes: Vec<BTreeSet<u32>> =
                passes.into_iter().map(|p| p.into_iter().collect()).collect();
            prop_assert_eq!((passes, cycles), expected.clone());
        }
    }

    /// Clouds of every shape (a filled disk, a ring, a thin line, a square with its corners,
    /// many copies of few points): the filtered hull has the same corners as the chain over
    /// every point.
    #[test]
    fn dropping_interior_points_keeps_every_hull_corner(
        shape in 0u32..5,
        count in 64usize..600,
        scale in 0.01f32..2000.0,
        seed in 0u64..1000,
    ) {
        let mut rng = crate::scene::rng::SplitMix64::new(seed);
        let centre = Vec2::new(rng.next_f32(), rng.next_f32()) * 1000.0;
        let points: Vec<Vec2> = (0..count)
            .map(|i| {
                let angle = rng.next_f32() * std::f32::consts::TAU;
                let radius = match shape {
                    0 => rng.next_f32().sqrt(),
                    1 => 1.0 - 0.01 * rng.next_f32(),
                    _ => rng.next_f32(),
                };
                let p = match shape {
                    2 => Vec2::new(radius, 0.5 * radius),
                    3 if i % 4 == 0 => Vec2::new((i / 4 % 2) as f32, (i / 8 % 2) as f32),
                    3 => Vec2::new(rng.next_f32(), rng.next_f32()),
                    4 => Vec2::new((i % 5) as f32, (i % 3) as f32),
                    _ => Vec2::from_angle(angle) * radius,
                };
                centre + p * scale
            })
            .collect();
        prop_assert_eq!(convex_hull(points.clone()), monotone_chain(points));
    }

    /// Rectangles from a pixel to most of the screen (so the tiles range from the smallest
    /// to the largest), some groups with no pixel, hulls that are triangles inside their
    /// rectangles: every pair whose rectangles overlap and whose hulls are not apart, each
    /// once.
    #[test]
    fn meeting_pairs_are_the_overlapping_pairs_each_once(
        groups in proptest::collection::vec(
            (0i32..300, 0i32..200, 0i32..4, 0.0f32..1.0, 0.0f32..1.0),
            1..80,
        ),
        size_scale in 0u32..4,
    ) {
        let (width, height) = (300u32, 200u32);
        let rects: Vec<Option<Rect>> = groups
            .iter()
            .map(|&(x, y, size, _, _)| {
                let side = [0, 2, 30, 250][size as usize] >> size_scale.min(size as u32);
                let r = Rect {
                    x0: x,
                    y0: y,
                    x1: (x + side).min(width as i32 - 1),
                    y1: (y + side).min(height as i32 - 1),
                };
                (x % 7 != 0).then_some(r)
            })
            .collect();
        // A triangle spanning its rectangle's left edge, bottom edge and a point of its top.
        let hulls: Vec<Option<Vec<Vec2>>> = rects
            .iter()
            .zip(&groups)
            .map(|(r, &(_, _, _, u, v))| {
                let r = (*r)?;
                let (lo, hi) = (
                    Vec2::new(r.x0 as f32, r.y0 as f32),
                    Vec2::new(r.x1 as f32, r.y1 as f32),
                );
                Some(vec![
                    lo,
                    Vec2::new(hi.x, lo.y + v * (hi.y - lo.y)),
                    Vec2::new(lo.x + u * (hi.x - lo.x), hi.y),
                ])
            })
            .collect();
        let visible: Vec<u32> = (0..groups.len() as u32).collect();
        let found = meeting_pairs(&visible, &rects, |g| hulls[g as usize].as_deref(), width, height);
        let unique: BTreeSet<(u32, u32)> = found.iter().copied().collect();
        prop_assert_eq!(unique.len(), found.len(), "a pair found twice");
        let mut expected = BTreeSet::new();
        for a in 0..groups.len() {
            for b in a + 1..groups.len() {
                let (Some(ra), Some(rb)) = (rects[a], rects[b]) else {
                    continue;
                };
                let overlap = ra.x0.max(rb.x0) <= ra.x1.min(rb.x1)
                    && ra.y0.max(rb.y0) <= ra.y1.min(rb.y1);
                let apart = hulls_apart(
                    hulls[a].as_ref().unwrap(),
                    hulls[b].as_ref().unwrap(),
                );
                if overlap && !apart {
                    expected.insert((a as u32, b as u32));
                }
            }
        }
        prop_assert_eq!(unique, expected);
    }
}

#[test]
fn a_group_between_pixel_centres_is_ordered_when_multisampled() {
    // One world unit per pixel, 8×8, looking down -z: a quad over the whole view at z = 2,
    // another behind it at z = 1, and behind both a sliver between pixel centres (x and y
    // in [2.6, 3.4]), which covers samples of 4× multisampling but no centre.
    let quad = |lo: f32, hi: f32, z: f32| {
        let [a, b, c, d] =
            [(lo, lo), (hi, lo), (hi, hi), (lo, hi)].map(|(x, y)| glam::Vec3::new(x, y, z));
        [[a, b, c], [a, c, d]]
    };
    let triangles = [
        quad(0.0, 8.0, 2.0),
        quad(0.0, 8.0, 1.0),
        quad(2.6, 3.4, 0.0),
    ]
    .concat();
    let dec = Decomposition::new(&triangles, &|_| {});
    assert_eq!(dec.groups.len(), 3);
    let group_at = |z: f32| dec.groups.iter().position(|g| g.lo.z == z).unwrap() as u32;
    let camera = Camera {
        eye: glam::Vec3::new(4.0, 4.0, 10.0),
        target: glam::Vec3::new(4.0, 4.0, 0.0),
        up: glam::Vec3::Y,
        projection: Projection::Orthographic { height: 8.0 },
        near: 0.1,
        far: 100.0,
    };
    let view_proj = camera.view_projection(1.0);
    let passes = |samples: u32| -> Vec<Vec<u32>> {
        sorted(
            plan(&dec, &camera, view_proj, 8, 8, samples)
                .passes
                .into_iter()
                .map(|pass| pass.into_iter().map(|(g, _)| g).collect())
                .collect(),
        )
    };
    let (front, middle, sliver) = (group_at(2.0), group_at(1.0), group_at(0.0));
    assert_eq!(passes(4), vec![vec![front], vec![middle], vec![sliver]]);
    // Single-sampled the sliver covers no pixel and meets nothing: any pass will do.
    let mut first = vec![front, sliver];
    first.sort();
    assert_eq!(passes(1), vec![first, vec![middle]]);
}

#[test]
fn tiles_follow_the_median_rectangle() {
    let square = |side: i32| Rect {
        x0: 0,
        y0: 0,
        x1: side - 1,
        y1: side - 1,
    };
    assert_eq!(tile_side(std::iter::empty()), 8);
    assert_eq!(tile_side([1, 3, 2].map(square).into_iter()), 8);
    assert_eq!(
        tile_side([1, 300, 300, 2, 400].map(square).into_iter()),
        512
    );
    assert_eq!(tile_side([5000; 3].map(square).into_iter()), 1024);
}

#[test]
fn the_filter_drops_most_of_a_filled_disk() {
    let points: Vec<Vec2> = (0..2000)
        .map(|i| {
            let (ring, step) = ((i / 100) as f32 / 20.0, (i % 100) as f32 / 100.0);
            Vec2::from_angle(step * std::f32::consts::TAU) * ring * 100.0
        })
        .collect();
    let mut kept = points.clone();
    drop_interior(&mut kept);
    // The 16-gon of extreme points holds every ring but the outer one.
    assert!(kept.len() <= 100, "{} of 2000 points kept", kept.len());
    assert_eq!(convex_hull(points.clone()), monotone_chain(points));
}
