//! CPU twin of setup.wgsl's 64-bit integers as (low, high) 32-bit words, for property tests
//! against `i64`. Keep in sync with `wide_*` in setup.wgsl.

/// A 64-bit integer as (low, high) words, as setup.wgsl keeps it.
pub type Wide = [u32; 2];

/// `v` as words.
pub fn from_i64(v: i64) -> Wide {
    [v as u32, (v >> 32) as u32]
}

/// The words as an i64.
pub fn to_i64(w: Wide) -> i64 {
    ((w[1] as u64) << 32 | w[0] as u64) as i64
}

/// a + b, carrying from the low word.
pub fn add(a: Wide, b: Wide) -> Wide {
    let lo = a[0].wrapping_add(b[0]);
    [lo, a[1].wrapping_add(b[1]).wrapping_add((lo < a[0]) as u32)]
}

/// −a (two's complement).
pub fn negate(a: Wide) -> Wide {
    let lo = (!a[0]).wrapping_add(1);
    [lo, (!a[1]).wrapping_add((lo == 0) as u32)]
}

/// a·b for |a|, |b| < 2³¹, from 16-bit partial products as the shader computes it.
pub fn mul(a: i32, b: i32) -> Wide {
    let (ua, ub) = (a.unsigned_abs(), b.unsigned_abs());
    let (a0, a1, b0, b1) = (ua & 0xffff, ua >> 16, ub & 0xffff, ub >> 16);
    let low = a0 * b0;
    let middle = a0 * b1 + a1 * b0;
    let lo = low.wrapping_add(middle << 16);
    let hi = a1 * b1 + (middle >> 16) + (lo < low) as u32;
    let product = [lo, hi];
    if (a < 0) != (b < 0) {
        negate(product)
    } else {
        product
    }
}

/// Whether a < 0.
pub fn negative(a: Wide) -> bool {
    (a[1] as i32) < 0
}

/// Whether a = 0.
pub fn zero(a: Wide) -> bool {
    a == [0, 0]
}
