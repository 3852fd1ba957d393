use super::*;
use proptest::prelude::*;

/// Coordinates the guard band allows: ±2²⁹ subpixels, differences below 2³⁰.
const RANGE: i32 = 1 << 30;

proptest! {
    /// The shader's 64-bit products, sums and signs equal i64 arithmetic over the guard band's
    /// range.
    #[test]
    fn wide_arithmetic_matches_i64(a in -RANGE..RANGE, b in -RANGE..RANGE, c in -RANGE..RANGE, d in -RANGE..RANGE) {
        let e = wide::add(wide::mul(a, b), wide::negate(wide::mul(c, d)));
        let exact = a as i64 * b as i64 - c as i64 * d as i64;
        prop_assert_eq!(wide::to_i64(e), exact);
        prop_assert_eq!(wide::negative(e), exact < 0);
        prop_assert_eq!(wide::zero(e), exact == 0);
        prop_assert_eq!(wide::from_i64(exact), e);
    }
}

#[test]
fn params_layout() {
    assert_eq!(std::mem::size_of::<RasterParams>(), 16);
}

/// The guard band keeps window coordinates within ±2²¹ pixels at every size.
#[test]
fn guard_band_bounds_window_coordinates() {
    for (w, h) in [(1, 1), (512, 512), (1920, 1080), (16384, 16384)] {
        let g = guard_band(w, h) as f64;
        let far = (g + 1.0) * 0.5 * w.max(h) as f64;
        assert!(far <= (1u64 << 21) as f64, "{w}x{h}: {far}");
        assert!(g >= 255.0);
    }
}
