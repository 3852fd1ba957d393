#define_import_path strata::fragment

// The fragment record every multi-fragment method stores: 16 bytes.
// depth: window-space z; tag: primitive index << 1 | front-facing bit; color as two f16 pairs.
// Keep in sync with `Fragment` in crates/strata/src/resolve/mod.rs. No bindings: applications'
// capture modules include this file.

struct Fragment {
    depth: f32,
    tag: u32,
    rg: u32,
    ba: u32,
}

fn fragment_new(depth: f32, prim: u32, front_facing: bool, color: vec4<f32>) -> Fragment {
    return Fragment(depth, (prim << 1u) | select(0u, 1u, front_facing), pack2x16float(color.rg), pack2x16float(color.ba));
}

fn fragment_color(f: Fragment) -> vec4<f32> {
    return vec4<f32>(unpack2x16float(f.rg), unpack2x16float(f.ba));
}

// The color exactly as storage holds it, its f16 bits decoded by hand. A compiler may fold
// unpack2x16float(pack2x16float(c)) back into c for a fragment its own invocation made, so
// `fragment_color` of a fresh fragment can be finer than of the same fragment read from memory.
// Where a sum must not depend on which fragments went through memory (a k-buffer's tail, which
// fragments reach directly or evicted from a slot, in an order the GPU picks), use this.
fn stored_color(f: Fragment) -> vec4<f32> {
    return vec4<f32>(half_bits(f.rg), half_bits(f.rg >> 16u), half_bits(f.ba), half_bits(f.ba >> 16u));
}

// The f16 in the low 16 bits of `h`, as an f32 (exact: every f16 is an f32).
fn half_bits(h: u32) -> f32 {
    let sign = (h & 0x8000u) << 16u;
    let exponent = (h >> 10u) & 0x1fu;
    let mantissa = h & 0x3ffu;
    if exponent == 0u {
        // Zero and subnormals: mantissa · 2⁻²⁴.
        let magnitude = f32(mantissa) * 5.9604645e-8;
        return select(magnitude, -magnitude, sign != 0u);
    }
    if exponent == 31u {
        return bitcast<f32>(sign | 0x7f800000u | (mantissa << 13u));
    }
    return bitcast<f32>(sign | ((exponent + 112u) << 23u) | (mantissa << 13u));
}

fn fragment_prim(f: Fragment) -> u32 {
    return f.tag >> 1u;
}

// The depth order every exact method follows: by depth, ties by primitive index.
fn fragment_before(a: Fragment, b: Fragment) -> bool {
    return a.depth < b.depth || (a.depth == b.depth && a.tag < b.tag);
}
