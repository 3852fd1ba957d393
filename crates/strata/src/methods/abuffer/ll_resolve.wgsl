// abuffer-ll resolve: walks a pixel's list; up to LOCAL_CAPACITY fragments are copied to a local
// array and insertion-sorted, longer lists are visited in order by repeated selection of the
// next fragment (O(n²), exact at any length). Then composites in (depth, primitive) order.

struct Node {
    fragment: Fragment,
    next: u32,
}

@group(1) @binding(0) var<storage, read_write> heads: array<u32>;
@group(1) @binding(1) var<storage, read_write> nodes: array<Node>;
@group(1) @binding(2) var<storage, read_write> output: array<vec4<f32>>;

const LOCAL_CAPACITY: u32 = 64u;

fn list_length(head: u32) -> u32 {
    var n = 0u;
    var at = head;
    while at != 0u {
        n += 1u;
        at = nodes[at - 1u].next;
    }
    return n;
}

@compute @workgroup_size(8, 8)
fn cs_resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let i = pixel_index(id.xy);
    let head = heads[i];
    let n = list_length(head);
    var s = composite_new();
    if n <= LOCAL_CAPACITY {
        var local: array<Fragment, LOCAL_CAPACITY>;
        var at = head;
        for (var j = 0u; j < n; j++) {
            let f = nodes[at - 1u].fragment;
            at = nodes[at - 1u].next;
            var k = j;
            while k > 0u && fragment_before(f, local[k - 1u]) {
                local[k] = local[k - 1u];
                k -= 1u;
            }
            local[k] = f;
        }
        for (var j = 0u; j < n; j++) {
            composite_front(&s, local[j]);
        }
    } else {
        var last = Fragment(-1.0, 0u, 0u, 0u);
        for (var j = 0u; j < n; j++) {
            var best = Fragment(3.0, 0u, 0u, 0u);
            var at = head;
            while at != 0u {
                let f = nodes[at - 1u].fragment;
                if fragment_before(last, f) && fragment_before(f, best) {
                    best = f;
                }
                at = nodes[at - 1u].next;
            }
            composite_front(&s, best);
            last = best;
        }
    }
    output[i] = composite_finish(s, id.xy);
}
