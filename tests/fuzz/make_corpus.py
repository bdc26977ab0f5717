#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpus (tests/fuzz/corpus/T) and regression corpus
(tests/fuzz/regressions/T): the seeds are valid inputs of every kind each reader takes, the
regressions the hostile inputs of issue 17's families, each of which must end in a clean
one-line refusal (tests/fuzz/CMakeLists.txt replays both in `make test`).

    python3 tests/fuzz/make_corpus.py build/app/btfsim

Raw and compressed BTF seeds are simulated with btfsim; crafted headers keep the file's other
bytes (the fuzz targets recompute stale checksums before reading, see fuzz_util.cpp). Inputs
that crashed a fuzzer are added to regressions/ by hand, named after what they found.
"""
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.join(ROOT, "tests", "fuzz")
MESH_EXT = {"obj": 0, "ply": 1, "off": 2}
IMAGE_EXT = {"png": 0, "exr": 1, "pgm": 2, "hdr": 3}


def put(kind, target, name, data):
    d = os.path.join(HERE, kind, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def seed(target, name, data):
    put("corpus", target, name, data)


def regression(target, name, data):
    put("regressions", target, name, data)


def scene(parts, size="[1, 1]", materials=None, extra=""):
    mats = materials or '{"m": {"type": "lambert", "albedo": 0.5}}'
    return ('{"btfscene": 1, "tile": {"size": %s}, "materials": %s, "parts": [%s]%s}'
            % (size, mats, parts, extra))


# ------------------------------------------------------------------------------ scenes
def scenes():
    for f in sorted(os.listdir(os.path.join(ROOT, "resources", "scenes"))):
        shutil.copy(os.path.join(ROOT, "resources", "scenes", f),
                    os.path.join(HERE, "corpus", "scene", f))
    small = {
        "plane": '{"type": "plane", "material": "m"}',
        "sine": '{"type": "sine", "material": "m", "resolution": [8, 8], "periods": [1, 2]}',
        "bumps": '{"type": "bumps", "material": "m", "resolution": [8, 8], "count": [2, 2]}',
        "vgrooves": '{"type": "vgrooves", "material": "m", "count": 2, "subdivisions": 1}',
        "noise": '{"type": "noise", "material": "m", "resolution": [8, 8], "octaves": 2}',
        "sphere": '{"type": "sphere", "material": "m", "segments": 8}',
        "box": '{"type": "box", "material": "m", "transform": {"rotate": [0, 0, 30]}}',
        "cylinder": '{"type": "cylinder", "material": "m", "segments": 6}',
        "cone": '{"type": "cone", "material": "m", "segments": 6, "array": {"count": [2, 2]}}',
        "torus": '{"type": "torus", "material": "m", "segments": [8, 4]}',
        "tube": '{"type": "tube", "material": "m", "segments": [8, 4]}',
    }
    for k, p in small.items():
        seed("scene", "part_" + k + ".json", scene(p))
    seed("scene", "materials.json", scene(
        '{"type": "plane", "material": "a"}, {"type": "box", "material": "b"}',
        materials='{"a": {"type": "cook_torrance", "roughness": 0.2}, '
                  '"b": {"type": "ward", "alpha_x": 0.1, "alpha_y": 0.2}}'))
    # Issue 17's scene families.
    regression("scene", "deep_nesting.json", "[" * 100000 + "]" * 100000)
    regression("scene", "deep_nesting_in_a_value.json",
               scene('{"type": "plane", "material": "m", "height": %s1%s}'
                     % ("[" * 5000, "]" * 5000)))
    regression("scene", "tile_1e38.json", scene('{"type": "plane", "material": "m"}', "[1e38, 1e38]"))
    regression("scene", "tile_1e-30.json", scene('{"type": "plane", "material": "m"}', "[1e-30, 1]"))
    regression("scene", "array_1024x1024.json", scene(
        '{"type": "sphere", "material": "m", "radius": 0.001, "segments": 256, '
        '"array": {"count": [1024, 1024]}}'))
    regression("scene", "heightfield_4096.json", scene(
        '{"type": "noise", "material": "m", "resolution": [4096, 4096]}'))
    regression("scene", "tube_4096.json", scene(
        '{"type": "tube", "material": "m", "segments": [4096, 4096]}'))
    regression("scene", "mesh_from_dev_zero.json", scene(
        '{"type": "mesh", "material": "m", "path": "/dev/zero"}'))
    regression("scene", "mesh_is_a_folder.json", scene(
        '{"type": "mesh", "material": "m", "path": "/tmp"}'))
    regression("scene", "image_from_dev_urandom.json", scene(
        '{"type": "image", "material": "m", "path": "/dev/urandom"}'))
    regression("scene", "mesh_missing.json", scene(
        '{"type": "mesh", "material": "m", "path": "no_such_mesh.ply"}'))
    regression("scene", "not_json.json", "{\"btfscene\": 1, \"tile\": ")
    regression("scene", "nan_height.json", scene('{"type": "plane", "material": "m", "height": NaN}'))
    regression("scene", "huge_number.json", scene('{"type": "plane", "material": "m", "height": 1e999}'))
    regression("scene", "unknown_material.json", scene('{"type": "plane", "material": "nope"}'))
    regression("scene", "wrong_type.json", scene('{"type": "sphere", "material": "m", "segments": "x"}'))
    regression("scene", "bad_utf8.json", b'{"btfscene": 1, "name": "\xff\xfe", "tile": {}}')


# ------------------------------------------------------------------------------ meshes
def ply_binary(verts, faces, endian="<", count_type="B", index_type="i"):
    fmt = "binary_little_endian" if endian == "<" else "binary_big_endian"
    names = {"B": "uchar", "i": "int", "I": "uint", "H": "ushort"}
    head = ("ply\nformat %s 1.0\ncomment fuzz seed\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nelement face %d\nproperty list %s %s "
            "vertex_indices\nend_header\n" % (fmt, len(verts), len(faces), names[count_type],
                                              names[index_type])).encode()
    body = b"".join(struct.pack(endian + "3f", *v) for v in verts)
    for f in faces:
        body += struct.pack(endian + count_type, len(f)) + struct.pack(
            endian + index_type * len(f), *f)
    return head + body


def ply_ascii(verts, faces):
    s = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
         "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
         % (len(verts), len(faces)))
    s += "".join("%g %g %g\n" % v for v in verts)
    s += "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in faces)
    return s


def off(verts, faces):
    s = "OFF\n%d %d 0\n" % (len(verts), len(faces))
    s += "".join("%g %g %g\n" % v for v in verts)
    s += "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in faces)
    return s


CUBE_V = [(-0.5, -0.5, -0.5), (0.5, -0.5, -0.5), (0.5, 0.5, -0.5), (-0.5, 0.5, -0.5),
          (-0.5, -0.5, 0.5), (0.5, -0.5, 0.5), (0.5, 0.5, 0.5), (-0.5, 0.5, 0.5)]
CUBE_F = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


def mesh(kind, name, ext, data):
    if isinstance(data, str):
        data = data.encode()
    put(kind, "mesh", name, bytes([MESH_EXT[ext]]) + data)


def meshes():
    for d in ("meshes", "objects"):
        for f in sorted(os.listdir(os.path.join(ROOT, "resources", d))):
            with open(os.path.join(ROOT, "resources", d, f), "rb") as fh:
                mesh("corpus", f, "obj", fh.read())
    tri_v = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    tri_f = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
    mesh("corpus", "cube_le.ply", "ply", ply_binary(CUBE_V, CUBE_F))
    mesh("corpus", "cube_be.ply", "ply", ply_binary(CUBE_V, CUBE_F, ">", "B", "I"))
    mesh("corpus", "tetra_ushort.ply", "ply", ply_binary(tri_v, tri_f, "<", "B", "H"))
    mesh("corpus", "cube_ascii.ply", "ply", ply_ascii(CUBE_V, CUBE_F))
    mesh("corpus", "cube.off", "off", off(CUBE_V, CUBE_F))
    mesh("corpus", "tetra.off", "off", "# comment\n" + off(tri_v, tri_f))
    good = ply_binary(CUBE_V, CUBE_F)
    body_at = good.index(b"end_header\n") + len(b"end_header\n")
    face_at = body_at + 12 * len(CUBE_V)
    # Issue 17's mesh family: binary PLY with flipped or zeroed bytes.
    b = bytearray(good)
    b[face_at] = 0xFF  # first face's vertex count 4 -> 255
    mesh("regressions", "ply_flipped_face_count.ply", "ply", bytes(b))
    b = bytearray(good)
    b[face_at + 1:face_at + 5] = b"\xff\xff\xff\x7f"  # an index of 2^31 - 1
    mesh("regressions", "ply_flipped_index.ply", "ply", bytes(b))
    b = bytearray(good)
    b[face_at + 1:face_at + 5] = b"\xff\xff\xff\xff"  # index -1
    mesh("regressions", "ply_negative_index.ply", "ply", bytes(b))
    b = bytearray(good)
    for k in range(face_at, len(b)):
        b[k] = 0
    mesh("regressions", "ply_zeroed_faces.ply", "ply", bytes(b))
    mesh("regressions", "ply_truncated.ply", "ply", good[:face_at + 7])
    mesh("regressions", "ply_huge_vertex_count.ply", "ply",
         good.replace(b"element vertex 8", b"element vertex 4000000000"))
    mesh("regressions", "ply_huge_face_count.ply", "ply",
         good.replace(b"element face 6", b"element face 999999999"))
    mesh("regressions", "ply_inf_vertex.ply", "ply",
         ply_binary([(math.inf, 0, 0)] + CUBE_V[1:], CUBE_F))
    mesh("regressions", "ply_nan_vertex_ascii.ply", "ply",
         ply_ascii([(0, 0, 0)] + CUBE_V[1:], CUBE_F).replace("0 0 0\n", "nan 0 0\n", 1))
    mesh("regressions", "ply_no_end_header.ply", "ply", good[:body_at - 11])
    mesh("regressions", "ply_property_less_element.ply", "ply",
         good.replace(b"element face 6", b"element junk 1000000\nelement face 6"))
    mesh("regressions", "obj_inf_vertex.obj", "obj", "v inf 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    mesh("regressions", "obj_index_past_end.obj", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    mesh("regressions", "obj_index_zero.obj", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
    mesh("regressions", "obj_no_faces.obj", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    mesh("regressions", "obj_repeated_vertex.obj", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 2\n")
    mesh("regressions", "off_huge_counts.off", "off", "OFF\n2000000000 2000000000 0\n0 0 0\n")
    mesh("regressions", "off_index_past_end.off", "off",
         "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    mesh("regressions", "off_binary.off", "off", b"OFF BINARY\n" + struct.pack(">3i", 3, 1, 0))
    mesh("regressions", "off_inf_vertex.off", "off", "OFF\n3 1 0\ninf 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    mesh("regressions", "off_formfeed_header.off", "off", "OFF\f0 0 20 \n \n")
    # Carriage returns inside the header line: OpenMesh read other counts and reserved 9.6 GB.
    mesh("regressions", "off_carriage_returns_header.off", "off",
         b"OFF\r\r\r\r\r\r\r0 0 7   4 7\x9d")
    mesh("regressions", "unknown_extension_byte", "obj", "")


# ------------------------------------------------------------------------------ images
def png(w, h, rows, bit_depth=8, colour=0):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    ihdr = struct.pack(">IIBBBBB", w, h, bit_depth, colour, 0, 0, 0)
    raw = b"".join(b"\x00" + r for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) +
            chunk(b"IEND", b""))


def hdr(w, h):
    s = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w)
    return s + bytes([128, 128, 128, 129]) * (w * h)


def image(kind, name, ext, data):
    put(kind, "image", name, bytes([IMAGE_EXT[ext]]) + data)


def images(btfsim, tmp):
    image("corpus", "grey4.png", "png", png(4, 4, [bytes([i * 16 + j * 4 for j in range(4)])
                                                   for i in range(4)]))
    image("corpus", "rgb2.png", "png", png(2, 2, [bytes(range(6)), bytes(range(6, 12))], 8, 2))
    image("corpus", "grey4.pgm", "pgm", b"P5 4 4 255\n" + bytes(range(0, 256, 16)))
    image("corpus", "grey3_ascii.pgm", "pgm", b"P2\n3 1\n255\n0 128 255\n")
    image("corpus", "grey2.hdr", "hdr", hdr(2, 2))
    exr = os.path.join(tmp, "slice.exr")
    subprocess.run([btfsim, "slice", os.path.join(tmp, "flat.btf"), "--view", "0,0", "--light",
                    "0,0", "-o", exr, "-q"], check=True)
    with open(exr, "rb") as f:
        image("corpus", "slice.exr", "exr", f.read())
    # Dimensions far past the bound, with valid checksums (PNG) or plain headers.
    image("regressions", "png_100000x100000.png", "png", png(100000, 100000, [b"\x00"]))
    image("regressions", "png_truncated.png", "png", png(4, 4, [b"\x00" * 4] * 4)[:40])
    image("regressions", "pgm_70000x70000.pgm", "pgm", b"P5 70000 70000 255\n\x00\x00")
    image("regressions", "pgm_truncated.pgm", "pgm", b"P5 64 64 255\n\x00\x00")
    image("regressions", "hdr_huge.hdr", "hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 90000 +X 90000\n")
    image("regressions", "not_an_image.png", "png", b"hello")
    image("regressions", "empty.exr", "exr", b"")


# ------------------------------------------------------------------------------ render references
def reference(kind, name, ext, data):
    put(kind, "reference", name, bytes([{"exr": 0, "png": 1}[ext]]) + data)


def references(btfsim, tmp):
    # An exact render's EXR (RGB + coverage alpha) of the flat tile, and an RGB PNG.
    exr = os.path.join(tmp, "exact.exr")
    subprocess.run([btfsim, "render", os.path.join(tmp, "flat.btf"), "--mode", "exact",
                    "--object", "sphere", "--size", "8", "--spp", "1", "-o", exr, "-q"],
                   check=True)
    with open(exr, "rb") as f:
        reference("corpus", "exact8.exr", "exr", f.read())
    reference("corpus", "rgb2.png", "png", png(2, 2, [bytes(range(6)), bytes(range(6, 12))], 8, 2))
    reference("regressions", "png_100000x100000.png", "png", png(100000, 100000, [b"\x00"]))
    reference("regressions", "png_truncated.png", "png", png(4, 4, [b"\x00" * 4] * 4)[:40])
    reference("regressions", "empty.exr", "exr", b"")
    with open(exr, "rb") as f:
        reference("regressions", "exr_truncated.exr", "exr", f.read()[:300])


# ------------------------------------------------------------------------------ BTFs
def split(path):
    with open(path, "rb") as f:
        b = f.read()
    n = struct.unpack("<Q", b[8:16])[0]
    return b, json.loads(b[24:24 + n]), n


def rewrite(b, n, header):
    """The file with another header; padded with spaces to the old length when shorter, so the
    layout after it (offsets, alignment) still holds and the crafted field is what is read."""
    h = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode()
    if len(h) < n:
        h += b" " * (n - len(h))
    return b[:8] + struct.pack("<Q", len(h)) + b[16:24] + h + b[24 + n:]


def btfs(btfsim, tmp):
    def run(*args):
        subprocess.run([btfsim, *args, "-q"], check=True, stdout=subprocess.DEVNULL)
    plane = os.path.join(tmp, "plane.json")
    with open(plane, "w") as f:
        f.write(scene('{"type": "plane", "material": "m"}'))
    brick = os.path.join(ROOT, "resources", "scenes", "brick.json")
    run("simulate", brick, "-o", os.path.join(tmp, "brick.btf"), "--texels", "2", "--dirs", "2x4",
        "--spp", "1", "--chunk-texels", "1")
    run("simulate", brick, "-o", os.path.join(tmp, "brick3.btf"), "--texels", "4x3", "--dirs",
        "3x4", "--spp", "1")
    run("simulate", plane, "-o", os.path.join(tmp, "flat.btf"), "--texels", "2", "--dirs", "2x4")
    for f in ("brick.btf", "brick3.btf", "flat.btf"):
        shutil.copy(os.path.join(tmp, f), os.path.join(HERE, "corpus", "btf", f))
    for codec in ("nmf", "svd", "perview", "lpca", "tensor", "neural"):
        out = os.path.join(tmp, codec + ".cbtf")
        extra = ["--neural-steps", "50"] if codec == "neural" else []
        run("compress", os.path.join(tmp, "brick3.btf"), "-o", out, "--codec", codec, *extra)
        shutil.copy(out, os.path.join(HERE, "corpus", "cbtf", codec + ".cbtf"))
    run("compress", os.path.join(tmp, "brick3.btf"), "-o", os.path.join(tmp, "mip.cbtf"),
        "--codec", "tensor", "--mip")
    shutil.copy(os.path.join(tmp, "mip.cbtf"), os.path.join(HERE, "corpus", "cbtf", "mip.cbtf"))
    run("compress", os.path.join(tmp, "brick.btf"), "-o", os.path.join(tmp, "ycc.cbtf"),
        "--codec", "nmf", "--colour-model", "rgb")
    shutil.copy(os.path.join(tmp, "ycc.cbtf"), os.path.join(HERE, "corpus", "cbtf", "nmf_rgb.cbtf"))

    b, h, n = split(os.path.join(tmp, "brick.btf"))

    def crafted(name, edit):
        j = json.loads(json.dumps(h))
        edit(j)
        regression("btf", name, rewrite(b, n, j))
    crafted("huge_texels.btf", lambda j: j.update(texels=[1000000, 4]))
    crafted("texels_overflow_layout.btf", lambda j: j.update(texels=[16384, 16384]))
    crafted("spp_not_a_number.btf", lambda j: j["settings"].update(spp="x"))
    crafted("no_directions.btf", lambda j: j["directions"].update(theta_phi_deg=[]))
    crafted("infinite_angle.btf",
            lambda j: j["directions"]["theta_phi_deg"][0].__setitem__(0, 1e999))
    crafted("angles_unlike_the_set.btf",
            lambda j: j["directions"]["theta_phi_deg"][0].__setitem__(0, 1e300))
    crafted("chunk_texels_zero.btf", lambda j: j.update(chunk_texels=0))
    crafted("plan_not_a_string.btf", lambda j: j.update(plan=[1, 2]))
    regression("btf", "deep_header.btf",
               b[:8] + struct.pack("<Q", 20000) + b[16:24] + b"[" * 10000 + b"]" * 10000)
    regression("btf", "header_past_end.btf", b[:8] + struct.pack("<Q", 1 << 40) + b[16:64])
    regression("btf", "truncated.btf", b[:len(b) - 100])
    regression("btf", "padded.btf", b + b"\x00" * 64)
    regression("btf", "bad_magic.btf", b"BTFSTORX" + b[8:])
    regression("btf", "empty.btf", b"")
    # A chunk holding NaN behind a valid checksum: decoders must not pass it on.
    nan = bytearray(b)
    data_at = len(b) - 4 * 64 * 12
    nan[data_at:data_at + 4] = struct.pack("<f", math.nan)
    seed("btf", "nan_value.btf", bytes(nan))

    c, ch, cn = split(os.path.join(tmp, "nmf.cbtf"))

    def ccrafted(name, edit, src=(c, ch, cn)):
        j = json.loads(json.dumps(src[1]))
        edit(j)
        regression("cbtf", name, rewrite(src[0], src[2], j))

    def nest(k):
        v = 1
        for _ in range(k):
            v = [v]
        return v
    sys.setrecursionlimit(10000)
    ccrafted("nested_params.cbtf", lambda j: j.update(params=nest(1000)))
    ccrafted("array_rows_overflow.cbtf",
             lambda j: j["arrays"][0].update(rows=1099511627776, cols=16777216))
    ccrafted("array_past_end.cbtf",
             lambda j: j["arrays"][0].update(offset=j["arrays"][0]["offset"] + 100000))
    ccrafted("array_inconsistent_bytes.cbtf", lambda j: j["arrays"][0].update(bytes=8))
    ccrafted("unknown_codec.cbtf", lambda j: j.update(codec="zip"))
    ccrafted("huge_texels.cbtf", lambda j: j["source"].update(texels=[16384, 16384]))
    ccrafted("array_type.cbtf", lambda j: j["arrays"][0].update(type="f64"))
    ccrafted("version.cbtf", lambda j: j.update(format_version=99))
    # Arrays whose shapes disagree with the header, one per codec (the decoders' own checks).
    for codec in ("nmf", "svd", "perview", "lpca", "tensor"):
        src = split(os.path.join(tmp, codec + ".cbtf"))

        def shrink(j):
            # Same bytes, another split into rows and columns: checksums and sizes still hold.
            for a in j["arrays"]:
                if a["rows"] % 2 == 0 and a["rows"] > 0:
                    a["rows"], a["cols"] = a["rows"] // 2, a["cols"] * 2
                    return
        ccrafted(codec + "_array_shapes.cbtf", shrink, src)
        ccrafted(codec + "_missing_array.cbtf", lambda j: j["arrays"].pop(), src)
    regression("cbtf", "raw_header_in_cbtf.cbtf", b"BTFCOMP1" + b[8:])
    # The visibility map a .cbtf carries: a grid or direction count unlike the file's, a block
    # past the end, a range upside down, a block that does not inflate to the map.
    ccrafted("vmf_directions.cbtf", lambda j: j["vmf"].update(directions=99))
    ccrafted("vmf_texels.cbtf", lambda j: j["vmf"].update(texels=[16384, 16384]))
    ccrafted("vmf_past_end.cbtf", lambda j: j["vmf"].update(offset=j["vmf"]["offset"] + 100000))
    ccrafted("vmf_range.cbtf", lambda j: j["vmf"].update(depth_range=[1, -1]))
    ccrafted("vmf_coder.cbtf", lambda j: j["vmf"].update(coder="lzma"))
    ccrafted("vmf_short_block.cbtf", lambda j: j["vmf"].update(bytes=3))
    # Pyramids whose level table does not follow from the texel grid.
    msrc = split(os.path.join(tmp, "mip.cbtf"))
    ccrafted("mip_wrong_level.cbtf", lambda j: j["levels"][1].update(texels=[9, 9]), msrc)
    ccrafted("mip_huge_first.cbtf", lambda j: j["levels"][2].update(first=1 << 60), msrc)
    ccrafted("mip_levels_not_a_list.cbtf", lambda j: j.update(levels={"a": 1}), msrc)
    ccrafted("mip_levels_dropped.cbtf", lambda j: j.pop("levels"), msrc)


# ------------------------------------------------------------------------------ pairs
def pairs():
    seed("pairs", "pairs.csv", "theta_i,phi_i,theta_o,phi_o\n30,0,30,180\n# c\n\n60 90 45 270\n")
    seed("pairs", "grazing.csv", "89.99,0,89.99,180\n0,0,0,0\n")
    regression("pairs", "theta_90.csv", "90,0,30,180\n")
    regression("pairs", "nan.csv", "30,0,30,180\nnan,0,30,180\n")
    regression("pairs", "inf_phi.csv", "30,inf,30,180\n")
    regression("pairs", "three_fields.csv", "30,0,30\n")
    regression("pairs", "five_fields.csv", "30,0,30,180,5\n")
    regression("pairs", "garbage.csv", "\x00\x01\x02\n")
    regression("pairs", "long_line.csv", "1," * 100000 + "\n")
    regression("pairs", "negative_theta.csv", "-1,0,30,180\n")


# ------------------------------------------------------------------------------ study tables
STUDY_HEAD = ("config,dirs,spp,shadows,bounces,voxels,gather,links,seconds,precompute_seconds,"
              "render_seconds,network_points,probe_rel_rmse,set_rel_rmse,probe_max_rel,"
              "image_rel_rmse,peak_rss_bytes,pareto\n")


def studies():
    row = '"network 16x32 spp2, P=3",16x32,2,map,3,32,16,16,%s,0.1,0.2,1152,%s,0.02,0.05,0.03,1000,%s\n'
    seed("study", "study.csv", STUDY_HEAD + row % ("1.5", "0.012", "1") + row % ("0.4", "0.05", "0"))
    seed("study", "reordered.csv", "pareto,seconds,probe_rel_rmse,config,spp,dirs\n1,2.0,0.1,a,1,8x16\n")
    regression("study", "missing_column.csv", "config,dirs,spp,seconds,pareto\na,8x16,1,2,1\n")
    regression("study", "nan_seconds.csv", STUDY_HEAD + row % ("nan", "0.01", "1"))
    regression("study", "negative_error.csv", STUDY_HEAD + row % ("1", "-0.01", "1"))
    regression("study", "short_row.csv", STUDY_HEAD + "a,b,1\n")
    regression("study", "pareto_2.csv", STUDY_HEAD + row % ("1", "0.01", "2"))
    regression("study", "huge_spp.csv", STUDY_HEAD + row.replace(",2,map", ",1e300,map") % ("1", "0.01", "1"))
    regression("study", "empty.csv", "")


def main():
    btfsim = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "build/app/btfsim")
    # Both folders also keep the fuzzers' findings (found_*: inputs that crashed, hung or broke a
    # contract before their fix); the rest is generated here.
    for kind in ("corpus", "regressions"):
        for t in os.listdir(os.path.join(HERE, kind)) if os.path.isdir(os.path.join(HERE, kind)) else []:
            for f in os.listdir(os.path.join(HERE, kind, t)):
                if not f.startswith("found_"):
                    os.remove(os.path.join(HERE, kind, t, f))
    for kind in ("corpus", "regressions"):
        for t in ("scene", "mesh", "image", "btf", "cbtf", "pairs", "study", "reference"):
            os.makedirs(os.path.join(HERE, kind, t), exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        scenes()
        meshes()
        btfs(btfsim, tmp)
        images(btfsim, tmp)
        references(btfsim, tmp)
        pairs()
        studies()


if __name__ == "__main__":
    main()
