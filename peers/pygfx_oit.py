#!/usr/bin/env python3
"""Render a glTF scene written by `strata export` with pygfx's transparency modes, offscreen.

Used by `strata bench peers`; runnable by hand:

    peers/.venv/bin/python peers/pygfx_oit.py scene.glb --mode weighted_blend \
        --size 256x256 --background '#333333' --frames 10 -o picture.png --json timings.json

Every material is drawn unlit (pygfx's MeshBasicMaterial) with the file's linear base color and
opacity, double-sided, with the requested alpha mode: `blend` (over-blending in pygfx's draw
order, no depth write), `weighted_blend` (weighted blended OIT, weight = alpha), `dither` and
`bayer` (stochastic transparency). Opaque materials (OPAQUE alpha mode) are drawn `solid`.
pygfx's defaults otherwise: objects sorted by depth (`sort_objects`); the internal resolution is
the output's and post-process anti-aliasing is off, as strata renders without anti-aliasing.

Timing: pygfx exposes no GPU timestamps, so each frame is timed on the wall clock from the start
of `render` to the end of the GPU's work (a 4-byte readback queued after it), after warm-up frames; the
picture itself is not read back inside the timed frames. The picture is read back once, after them.

Errors are one line on stderr and exit status 2.
"""

import argparse
import json
import math
import struct
import sys
import time


def fail(message):
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


COMPONENTS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}
DTYPES = {5126: "<f4", 5125: "<u4", 5123: "<u2", 5121: "u1"}


def read_glb(path):
    """The JSON document and binary chunk of a .glb (or the JSON and embedded buffer of a .gltf)."""
    import base64

    try:
        data = open(path, "rb").read()
    except OSError as e:
        fail(f"{path}: {e.strerror}")
    if data[:4] == b"glTF":
        if len(data) < 20:
            fail(f"{path}: truncated GLB")
        json_len = struct.unpack_from("<I", data, 12)[0]
        doc = json.loads(data[20 : 20 + json_len])
        rest = data[20 + json_len :]
        binary = rest[8 : 8 + struct.unpack_from("<I", rest, 0)[0]] if len(rest) >= 8 else b""
        return doc, binary
    doc = json.loads(data)
    uri = doc["buffers"][0].get("uri", "")
    prefix = "data:application/octet-stream;base64,"
    if not uri.startswith(prefix):
        fail(f"{path}: only .glb files and .gltf files with an embedded buffer are read")
    return doc, base64.b64decode(uri[len(prefix) :])


def accessor(doc, binary, index):
    import numpy as np

    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    if a["componentType"] not in DTYPES or view.get("byteStride"):
        fail("accessor layout not written by strata export")
    n = COMPONENTS[a["type"]]
    offset = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    out = np.frombuffer(binary, dtype=DTYPES[a["componentType"]], count=a["count"] * n, offset=offset)
    return out.reshape(a["count"], n) if n > 1 else out


def node_matrix(node):
    import numpy as np
    import pylinalg as la

    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    t = node.get("translation", [0, 0, 0])
    r = node.get("rotation", [0, 0, 0, 1])
    s = node.get("scale", [1, 1, 1])
    return la.mat_compose(t, r, s)


def linear_to_srgb(c):
    c = min(max(c, 0.0), 1.0)
    return c * 12.92 if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055


def write_png(path, rgba):
    """An 8-bit RGBA PNG of an (h, w, 4) uint8 array, written whole or not at all."""
    import os
    import zlib

    import numpy as np

    h, w, _ = rgba.shape
    rows = np.concatenate([np.zeros((h, 1), np.uint8), np.ascontiguousarray(rgba, np.uint8).reshape(h, w * 4)], axis=1)

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + chunk(b"IEND", b"")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(png)
    os.replace(tmp, path)


def parse_size(text):
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        fail(f"--size '{text}' is not WxH")
    if w <= 0 or h <= 0:
        fail(f"--size '{text}' must be positive")
    return w, h


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="a .glb (or embedded .gltf) written by strata export")
    p.add_argument("--mode", default="weighted_blend", choices=["blend", "weighted_blend", "dither", "bayer"])
    p.add_argument("--size", default="256x256")
    p.add_argument("--background", default="#333333", help="#rrggbb (sRGB)")
    p.add_argument("--frames", type=int, default=10)
    p.add_argument("--warmup", type=int, default=2)
    p.add_argument("-o", "--output", required=True, help="the last frame, as PNG")
    p.add_argument("--json", help="timings and device, as JSON")
    a = p.parse_args()
    width, height = parse_size(a.size)
    if a.frames < 1 or a.warmup < 0:
        fail("--frames must be at least 1 and --warmup at least 0")

    try:
        import numpy as np
        import pygfx as gfx
        import wgpu
    except ImportError as e:
        fail(f"pygfx is not installed ({e}): run peers/setup")

    doc, binary = read_glb(a.scene)
    scene = gfx.Scene()
    scene.add(gfx.Background.from_color(a.background))
    materials = []
    for m in doc.get("materials", []):
        r, g, b, alpha = m["pbrMetallicRoughness"].get("baseColorFactor", [1, 1, 1, 1])
        srgb = tuple(linear_to_srgb(c) for c in (r, g, b))
        mode = a.mode if m.get("alphaMode", "OPAQUE") == "BLEND" else "solid"
        materials.append(gfx.MeshBasicMaterial(color=srgb, opacity=alpha, alpha_mode=mode, side="both"))

    camera = None
    for index in doc["scenes"][doc.get("scene", 0)]["nodes"]:
        node = doc["nodes"][index]
        if "mesh" in node:
            prim = doc["meshes"][node["mesh"]]["primitives"][0]
            positions = accessor(doc, binary, prim["attributes"]["POSITION"]).astype(np.float32)
            indices = accessor(doc, binary, prim["indices"]).astype(np.int32).reshape(-1, 3)
            geometry = gfx.Geometry(positions=positions, indices=indices)
            mesh = gfx.Mesh(geometry, materials[prim["material"]])
            mesh.local.matrix = node_matrix(node)
            scene.add(mesh)
        elif "camera" in node and camera is None:
            c = doc["cameras"][node["camera"]]
            aspect = width / height
            if c["type"] == "perspective":
                persp = c["perspective"]
                # pygfx's fov spans the mean of width and height; glTF's yfov the height.
                fov = 2 * math.degrees(math.atan((1 + aspect) / 2 * math.tan(persp["yfov"] / 2)))
                camera = gfx.PerspectiveCamera(fov, aspect, maintain_aspect=False)
                camera.depth_range = (persp["znear"], persp.get("zfar", persp["znear"] * 1e4))
            else:
                ortho = c["orthographic"]
                camera = gfx.OrthographicCamera(2 * ortho["ymag"] * aspect, 2 * ortho["ymag"], maintain_aspect=False)
                camera.depth_range = (ortho["znear"], ortho["zfar"])
            camera.local.matrix = node_matrix(node)
    if camera is None:
        fail(f"{a.scene}: no camera node (write it with strata export)")

    # pygfx writes sRGB-encoded values into a plain unorm target (an -srgb one draws a warning).
    target = gfx.Texture(dim=2, size=(width, height, 1), format="rgba8unorm")
    # One internal pixel per output pixel and no post-process anti-aliasing (pygfx's default
    # "ddaa"), as strata draws: edge pixels would otherwise differ by design, not by method.
    renderer = gfx.renderers.WgpuRenderer(target, pixel_scale=1, ppaa="none")
    device = renderer.device
    # on_submitted_work_done_sync fails in wgpu-py 0.32 (a callback signature mismatch with its
    # wgpu-native); reading back 4 bytes waits for every earlier submission just the same.
    fence = device.create_buffer(size=4, usage=wgpu.BufferUsage.COPY_SRC | wgpu.BufferUsage.COPY_DST)
    times = []
    for i in range(a.warmup + a.frames):
        start = time.perf_counter()
        renderer.render(scene, camera)
        device.queue.read_buffer(fence)
        if i >= a.warmup:
            times.append((time.perf_counter() - start) * 1e3)
    picture = np.asarray(renderer.snapshot())[:, :, :4]

    write_png(a.output, picture)
    info = device.adapter.info
    if a.json:
        result = {
            "peer": "pygfx",
            "version": gfx.__version__,
            "wgpu_py": wgpu.__version__,
            "mode": a.mode,
            "width": width,
            "height": height,
            "frames": a.frames,
            "warmup": a.warmup,
            "adapter": info.get("device", ""),
            "adapter_type": info.get("adapter_type", ""),
            "wall_ms": times,
            "median_wall_ms": sorted(times)[len(times) // 2] if len(times) % 2 else sum(sorted(times)[len(times) // 2 - 1 : len(times) // 2 + 1]) / 2,
        }
        with open(a.json, "w") as f:
            json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
