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

fn fragment_prim(f: Fragment) -> u32 {
    return f.tag >> 1u;
}

// The depth order every exact method follows: by depth, ties by primitive index.
fn fragment_before(a: Fragment, b: Fragment) -> bool {
    return a.depth < b.depth || (a.depth == b.depth && a.tag < b.tag);
}
