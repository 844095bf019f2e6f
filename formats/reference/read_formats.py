#!/usr/bin/env python3
"""Reference reader for .texel and .instances, written from formats/*.md alone.

usage: read_formats.py [--check-golden] [--expect-invalid] FILE...
"""
import hashlib, math, os, struct, sys, zlib
from array import array
import zstandard

class Bad(Exception):
    pass

MAGIC = {b"\x89TEXEL\r\n": "texel", b"\x89TXINST\n": "instances"}
MAJOR, MINOR = {"texel": 1, "instances": 1}, {"texel": 7, "instances": 1}
CELL_LIMIT, TREE_LIMIT = 2**25, 2**24           # the reader's allocation limits (texel's defaults)

def f32(x):  # round a Python float to binary32
    return struct.unpack("<f", struct.pack("<f", x))[0]

def short32(x):  # shortest decimal that round-trips as binary32
    return next(s for s in (f"{x:.{p}g}" for p in range(1, 10)) if f32(float(s)) == x)

class Cur:
    """bincode 2, standard().with_little_endian().with_fixed_int_encoding()."""
    def __init__(self, b): self.b, self.p = b, 0
    def take(self, n):
        if n > len(self.b) - self.p: raise Bad(f"header does not decode: needs {n} bytes at header offset {self.p}, {len(self.b) - self.p} left")
        self.p += n
        return self.b[self.p - n:self.p]
    def un(self, fmt): return struct.unpack("<" + fmt, self.take(struct.calcsize(fmt)))
    def u8(self): return self.un("B")[0]
    def u32(self): return self.un("I")[0]
    def u64(self): return self.un("Q")[0]
    def f32(self): return self.un("f")[0]
    def f64(self): return self.un("d")[0]
    def f64s(self, n): return list(self.un(f"{n}d"))
    def bool(self):
        v = self.u8()
        if v > 1: raise Bad(f"header does not decode: bool byte {v}")
        return v == 1
    def string(self):
        try: return self.take(self.u64()).decode("utf-8")
        except UnicodeDecodeError: raise Bad("header does not decode: string is not UTF-8")
    def vec(self, item): return [item() for _ in range(self.u64())]
    def option(self, item):
        tag = self.u8()
        if tag > 1: raise Bad(f"header does not decode: Option tag {tag}")
        return item() if tag else None
    def enum(self, names):
        v = self.u32()
        if v >= len(names): raise Bad(f"header does not decode: enum variant {v} of {names}")
        return names[v]
    def source(self): return {"path": self.string(), "sha256": self.take(32), "bytes": self.u64()}

# ---------------------------------------------------------------- container (container.md, Reading 1-6)
def read_file(path):
    data = open(path, "rb").read()
    if len(data) < 8 or data[:8] not in MAGIC:                                        # 1
        raise Bad("not a texel-forest file: shorter than 8 bytes or unknown magic")
    fmt = MAGIC[data[:8]]
    if len(data) < 10: raise Bad("truncated before the major version")
    major = struct.unpack_from("<H", data, 8)[0]
    if major != MAJOR[fmt]: raise Bad(f"major version {major}, this reader implements {MAJOR[fmt]}")  # 2
    if len(data) < 32: raise Bad(f"truncated: {len(data)} bytes, the container header alone is 32")
    minor, H, R, P = struct.unpack_from("<HIQQ", data, 10)
    if H > 16 * 2**20: raise Bad(f"H = {H} exceeds 16 MiB")                           # 3
    if R > 2 * 2**30: raise Bad(f"R = {R} exceeds 2 GiB")
    if P > R + R // 128 + 4096: raise Bad(f"P = {P} exceeds what zstd makes of R = {R} bytes")
    if len(data) != 36 + H + P:
        raise Bad(f"file is {len(data)} bytes, 36+H+P = {36 + H + P}: " + ("truncated" if len(data) < 36 + H + P else "trailing data"))
    crc = struct.unpack_from("<I", data, 32 + H + P)[0]                                # 4
    if zlib.crc32(data[:32 + H + P]) != crc: raise Bad("CRC-32 mismatch")
    c = Cur(data[32:32 + H])                                                           # 5
    hdr = (read_texel_header if fmt == "texel" else read_instances_header)(c, minor, R)
    if c.p != H and minor <= MINOR[fmt]:
        raise Bad(f"header leaves {H - c.p} bytes over (file minor {minor} is not newer than {MINOR[fmt]})")
    payload = decompress(data[32 + H:32 + H + P], R)                                  # 6
    hdr.update(fmt=fmt, version=(major, minor), H=H, R=R, P=P, size=len(data), sha256=hashlib.sha256(data).hexdigest())
    (read_texel_payload if fmt == "texel" else read_instances_payload)(hdr, payload)
    return hdr

def decompress(p, R):
    """One zstd frame (RFC 8878 3.1.1) filling all P bytes, content size = R, no dictionary."""
    if len(p) < 6 or p[:4] != b"\x28\xb5\x2f\xfd": raise Bad("payload does not start with a zstd frame (28 B5 2F FD)")
    fhd = p[4]
    fcs_flag, single, reserved, checksum, did_flag = fhd >> 6, fhd >> 5 & 1, fhd >> 3 & 1, fhd >> 2 & 1, fhd & 3
    if reserved: raise Bad("zstd frame header reserved bit set")
    pos = 6 if not single else 5
    did_n, fcs_n = (0, 1, 2, 4)[did_flag], (1 if single else 0, 2, 4, 8)[fcs_flag]
    if pos + did_n + fcs_n > len(p): raise Bad("zstd frame header truncated")
    if int.from_bytes(p[pos:pos + did_n], "little"): raise Bad("zstd frame names a dictionary")
    pos += did_n
    if fcs_n == 0: raise Bad("zstd frame does not declare its content size")
    fcs = int.from_bytes(p[pos:pos + fcs_n], "little") + (256 if fcs_n == 2 else 0)
    pos += fcs_n
    if fcs != R: raise Bad(f"zstd frame declares content size {fcs}, R = {R}")
    while True:  # walk the blocks to find where the frame ends
        if pos + 3 > len(p): raise Bad("zstd frame truncated")
        bh = int.from_bytes(p[pos:pos + 3], "little")
        pos += 3
        if bh >> 1 & 3 == 3: raise Bad("zstd block of reserved type")
        pos += 1 if bh >> 1 & 3 == 1 else bh >> 3
        if bh & 1: break
    pos += 4 if checksum else 0  # a content checksum is allowed, and checked by the decoder
    if pos != len(p):
        raise Bad("zstd frame truncated" if pos > len(p) else f"{len(p) - pos} bytes after the zstd frame")
    out = bytearray()
    try:
        rd = zstandard.ZstdDecompressor().stream_reader(p, read_across_frames=False)
        while chunk := rd.read(min(1 << 20, R + 1 - len(out))):  # never more than R+1 bytes
            out += chunk
            if len(out) > R: raise Bad(f"payload decompresses to more than R = {R} bytes")
    except zstandard.ZstdError as e:
        raise Bad(f"zstd error: {e}")
    if len(out) != R: raise Bad(f"payload decompresses to {len(out)} bytes, R = {R}")
    return bytes(out)

# ---------------------------------------------------------------- .texel (texel.md)
F32, U16 = "F32", "Unorm16"
REQUIRED = {"density_wood": (1, F32), "density_foliage": (1, F32), "gradient_wood": (3, F32),
            "gradient_foliage": (3, F32), "albedo_wood": (3, U16), "albedo_foliage": (3, U16)}
REASONS = ["WoodPattern", "FoliagePattern", "AlphaCuts", "Solid"]

def read_texel_header(c, minor, R):
    h = {"generator": c.string(), "model_min": c.f64s(3), "model_max": c.f64s(3), "origin": c.f64s(3),
         "density_model": c.enum(["Occupancy", "Transmittance"]), "extinction_scale": c.f64(),
         "triangles": c.u64(), "foliage_triangles": c.u64(), "mesh_coverage": c.f64s(3),
         "sources": c.vec(c.source), "inputs_sha256": c.take(32),
         "parameters": {"resolution": c.u32(), "fine": c.u32(), "foliage_pattern": c.string(),
                        "requested_gamma": c.option(c.f64)},
         "levels": c.vec(lambda: {"dims": list(c.un("3I")), "cell": c.f64()}),
         "channels": c.vec(lambda: {"name": c.string(), "components": c.u8(), "encoding": c.enum([F32, U16]), "unit": c.string()}),
         "wood_pattern": None, "materials": [], "directional": None, "self_shadow": None, "wood_weight": None,
         "self_shadow_by_height": None, "self_shadow_by_view": None}
    if minor >= 1:
        h["wood_pattern"] = c.option(c.string)
        h["materials"] = c.vec(lambda: {"name": c.string(), "reason": c.enum(REASONS), "cut": c.f32(), "triangles": c.u64()})
    if minor >= 2:
        h["directional"] = c.vec(lambda: list(c.un("7f")))
        h["self_shadow"] = c.vec(lambda: list(c.un("6f")))
        h["wood_weight"] = c.vec(c.f32)
    if minor >= 5:
        h["self_shadow_by_height"] = c.vec(lambda: [list(c.un("6f")) for _ in range(4)])
    if minor >= 6:
        # [eye height 10, 35, 60][sun turn 0, 90, 180], each a row at the six angles
        h["self_shadow_by_view"] = c.vec(lambda: [[list(c.un("6f")) for _ in range(3)] for _ in range(3)])
    if not all(map(math.isfinite, h["model_min"] + h["model_max"] + h["origin"])): raise Bad("1: non-finite model_min, model_max or origin")
    g = h["extinction_scale"]
    if not (math.isfinite(g) and g > 0): raise Bad(f"2: extinction_scale {g} is not positive and finite")
    L = h["levels"]
    if not 1 <= len(L) <= 16: raise Bad(f"3: {len(L)} levels (1 to 16)")
    if not all(1 <= d <= 4096 for d in L[0]["dims"]) or not (math.isfinite(L[0]["cell"]) and L[0]["cell"] > 0):
        raise Bad(f"4: level 0 dims {L[0]['dims']} or cell {L[0]['cell']} out of range")
    for n in range(len(L) - 1):
        if L[n]["dims"] == [1, 1, 1]: raise Bad(f"6: level {n + 1} after a 1x1x1 level")
        if L[n + 1]["dims"] != [(d + 1) // 2 for d in L[n]["dims"]] or L[n + 1]["cell"] != 2 * L[n]["cell"]:
            raise Bad(f"5: level {n + 1} is not half of level {n}")
    if L[-1]["dims"] != [1, 1, 1]: raise Bad("6: last level is not 1x1x1")
    ch = h["channels"]
    if len(ch) > 64: raise Bad(f"7: {len(ch)} channels")
    for k in ch:
        if not 1 <= k["components"] <= 16: raise Bad(f"7: channel {k['name']!r} has {k['components']} components")
    if len({k["name"] for k in ch}) != len(ch): raise Bad("7: two channels of the same name")
    if h["foliage_triangles"] > h["triangles"]: raise Bad("8: foliage_triangles > triangles")
    M = h["materials"]
    if len(M) > 65536: raise Bad(f"9: {len(M)} materials")
    if M and sum(m["triangles"] for m in M) != h["triangles"]: raise Bad("9: material triangles do not add up to triangles")
    if M and sum(m["triangles"] for m in M if m["reason"] in REASONS[1:3]) != h["foliage_triangles"]:
        raise Bad("9: foliage material triangles do not add up to foliage_triangles")
    if any(not 0 <= m["cut"] <= 1 for m in M): raise Bad("9: a material cut outside [0, 1]")
    D = h["directional"]
    if D is not None:
        if len(D) != len(L): raise Bad(f"9b: {len(D)} directional forms for {len(L)} levels")
        if any(not (math.isfinite(v) and abs(v) <= 4096) for form in D for v in form): raise Bad("9b: a directional form entry out of range")
        K = h["self_shadow"]
        if len(K) != len(L): raise Bad(f"9b: {len(K)} self-shadowing rows for {len(L)} levels")
        if any(not 0 <= v <= 64 for row in K for v in row): raise Bad("9b: a self-shadowing factor outside [0, 64]")
        W = h["wood_weight"]
        if len(W) != len(L): raise Bad(f"9b: {len(W)} wood weights for {len(L)} levels")
        if any(not 1 / 4096 <= w <= 4096 for w in W): raise Bad("9b: a wood weight outside [1/4096, 4096]")
    else:
        h["directional"] = [[1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0] for _ in L]
        h["self_shadow"] = [[1.0] * 6 for _ in L]
        h["wood_weight"] = [1.0 for _ in L]
    KH = h["self_shadow_by_height"]
    if KH is not None:
        if len(KH) != len(L): raise Bad(f"9c: {len(KH)} self-shadowing entries by sun height for {len(L)} levels")
        if any(not 0 <= v <= 64 for rows in KH for row in rows for v in row): raise Bad("9c: a self-shadowing factor by sun height outside [0, 64]")
    else:
        # Before 1.5 the pooled row serves every height of the sun.
        h["self_shadow_by_height"] = [[list(row)] * 4 for row in h["self_shadow"]]
    KV = h["self_shadow_by_view"]
    if KV is not None:
        if len(KV) != len(L): raise Bad(f"9d: {len(KV)} self-shadowing entries by eye height and sun turn for {len(L)} levels")
        if any(not 0 <= v <= 64 for sets in KV for rows in sets for row in rows for v in row): raise Bad("9d: a self-shadowing factor by eye height and sun turn outside [0, 64]")
    cells = sum(math.prod(l["dims"]) for l in L)
    per_cell = sum(k["components"] * (4 if k["encoding"] == F32 else 2) for k in ch)
    if cells * per_cell != R: raise Bad(f"10: header implies a payload of {cells * per_cell} bytes, R = {R}")
    have = {k["name"]: (k["components"], k["encoding"]) for k in ch}
    for name, want in REQUIRED.items():
        if have.get(name) != want: raise Bad(f"11: channel {name} missing or not {want[0]} x {want[1]} (got {have.get(name)})")
    for name in ("leaves_foliage", "normals_wood"):
        if name in have and have[name] != (6, F32): raise Bad(f"11: channel {name} is not 6 x F32 (got {have[name]})")
    solids = [n for n in ("solid_wood", "solid_foliage") if n in have]
    if len(solids) == 1: raise Bad(f"11: channel {solids[0]} without its pair")
    for n in solids:
        if have[n] != (1, U16): raise Bad(f"11: channel {n} is not 1 x Unorm16 (got {have[n]})")
    if "shown_wood" in have and have["shown_wood"] != (1, F32): raise Bad(f"11: channel shown_wood is not 1 x F32 (got {have['shown_wood']})")
    if cells > CELL_LIMIT: raise Bad(f"{cells} cells, more than this reader's limit of {CELL_LIMIT}")
    return h

def read_texel_payload(h, payload):
    pos, h["data"] = 0, []
    for n, lvl in enumerate(h["levels"]):
        cells, chans = math.prod(lvl["dims"]), {}
        for k in h["channels"]:
            a = array("f" if k["encoding"] == F32 else "H")
            size = cells * k["components"] * a.itemsize
            a.frombytes(payload[pos:pos + size])
            if sys.byteorder == "big": a.byteswap()
            pos += size
            chans[k["name"]] = a
        for name in ("density_wood", "density_foliage", "shown_wood"):
            if name in chans and any(not math.isfinite(v) or v < 0 for v in chans[name]): raise Bad(f"12: level {n}: a negative or non-finite {name}")
        for name in ("gradient_wood", "gradient_foliage"):
            if not all(map(math.isfinite, chans[name])): raise Bad(f"12: level {n}: a non-finite {name}")
        for name in ("leaves_foliage", "normals_wood"):
            if name not in chans: continue
            lv = chans[name]
            for i in range(0, len(lv), 6):
                if not (all(0 <= v <= 1 for v in lv[i:i + 3]) and all(-1 <= v <= 1 for v in lv[i + 3:i + 6])):
                    raise Bad(f"12: level {n}: {name} {list(lv[i:i + 6])} is no moment of unit vectors")
        h["data"].append(chans)

def directional_factor(form, w):  # k_n(w) of formats/texel.md, for any non-zero w
    n = math.sqrt(sum(v * v for v in w)); x, y, z = (v / n for v in w)
    xx, yy, zz, xy, xz, yz, c = form
    q = xx * x * x + yy * y * y + zz * z * z + 2 * (xy * x * y + xz * x * z + yz * y * z) + c * (x ** 4 + y ** 4 + z ** 4)
    return math.sqrt(max(q, 1 / 4096))

def cell_values(h, level, x, y, z):
    nx, ny, _ = h["levels"][level]["dims"]
    i, ch = x + nx * (y + ny * z), h["data"][level]
    return {k: [v / 65535 if isinstance(v, int) else v for v in ch[k][i * c:(i + 1) * c]]
            for k, c in ((k["name"], k["components"]) for k in h["channels"])}

def texel_summary(h):
    p = h["parameters"]
    print(f"  generator {h['generator']!r}; {h['density_model']}, extinction_scale {h['extinction_scale']}; triangles {h['triangles']}, foliage {h['foliage_triangles']}")
    print(f"  resolution {p['resolution']}, fine {p['fine']}, foliage_pattern {p['foliage_pattern']!r}, gamma {p['requested_gamma']}; wood_pattern {h['wood_pattern']!r}")
    print("  sources: " + ", ".join(f"{s['path']} ({s['bytes']} B)" for s in h["sources"]))
    ok = hashlib.sha256(b"".join(s["sha256"] for s in h["sources"])).digest() == h["inputs_sha256"]
    print(f"  inputs_sha256 {h['inputs_sha256'].hex()[:16]}... ({'matches' if ok else 'DOES NOT match'} the sources' digests; not a listed check)")
    for m in h["materials"]: print(f"  material {m['name']!r}: {m['reason']}, cut {m['cut']}, {m['triangles']} triangles")
    for n, form in enumerate(h["directional"]):
        print(f"  level {n} directional form {[short32(v) for v in form]}: k along x, y, z {[round(directional_factor(form, w), 4) for w in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]}")
    for n, row in enumerate(h["self_shadow"]):
        print(f"  level {n} self-shadowing at 0, 15, 30, 60, 90, 180 degrees {[short32(v) for v in row]}; wood weight {short32(h['wood_weight'][n])}")
        for height, r in zip((0, 30, 60, 90), h["self_shadow_by_height"][n]):
            print(f"    with the sun {height} degrees high {[short32(v) for v in r]}")
        for eye, rows in zip((10, 35, 60), h["self_shadow_by_view"][n] if h["self_shadow_by_view"] else []):
            for turn, r in zip((0, 90, 180), rows):
                print(f"    with the eye {eye} degrees high, the sun turned {turn} degrees about its line of sight {[short32(v) for v in r]}")
    print("  channels: " + ", ".join(f"{k['name']}[{k['components']} {k['encoding']} {k['unit']}]" for k in h["channels"]))
    for n, (l, ch) in enumerate(zip(h["levels"], h["data"])):
        print(f"  level {n}: {'x'.join(map(str, l['dims']))} of {l['cell']!r} m; sum density_wood {math.fsum(ch['density_wood']):.10g}, density_foliage {math.fsum(ch['density_foliage']):.10g}")

# ---------------------------------------------------------------- .instances (instances.md)
def read_instances_header(c, minor, R):
    def season(): return {"day": c.f64(), "albedo": c.f64s(3)}
    def leaf(): return {"day": c.f64(), "value": c.f64()}
    def species():
        return {"name": c.string(), "texel": c.string(), "texel_sha256": c.take(32),
                "leafless_texel": c.option(c.string), "leafless_sha256": c.option(lambda: c.take(32)),
                "model_height": c.f64(), "spacing": c.f64(), "height_min": c.f64(), "height_max": c.f64(),
                "traits": [c.enum(["conifer", "broadleaf"]), c.enum(["shade_tolerant", "sun_loving"]),
                           c.enum(["evergreen", "deciduous"]), c.enum(["successive", "simultaneous"]),
                           c.enum(["red", "yellow", "none"])],
                "foliage": c.vec(season), "leaf_fraction": c.vec(leaf)}
    h = {"generator": c.string(), "terrain": c.vec(c.source), "species_file": c.source(), "seed": c.u64(),
         "region": c.f64s(4), "raster_cell": c.f64(), "max_count": c.u64(), "truncated": c.bool(),
         "terrain_min": c.f64s(3), "terrain_max": c.f64s(3), "origin": c.f64s(3), "species": c.vec(species), "count": c.u64()}
    if not all(map(math.isfinite, h["region"] + h["terrain_min"] + h["terrain_max"] + h["origin"])):
        raise Bad("2: non-finite region, terrain_min, terrain_max or origin")
    x0, z0, x1, z1 = h["region"]
    if x0 >= x1 or z0 >= z1: raise Bad(f"2: empty region {h['region']}")
    if not (math.isfinite(h["raster_cell"]) and h["raster_cell"] > 0): raise Bad("2: raster_cell not positive and finite")
    if not 1 <= len(h["species"]) <= 255: raise Bad(f"3: {len(h['species'])} species (1 to 255)")
    for s in h["species"]:
        for f in ("model_height", "spacing", "height_min", "height_max"):
            if not (math.isfinite(s[f]) and s[f] > 0): raise Bad(f"4: species {s['name']!r}: {f} {s[f]} not positive and finite")
        if s["height_min"] > s["height_max"]: raise Bad(f"4: species {s['name']!r}: height_min > height_max")
        if (s["leafless_texel"] is None) != (s["leafless_sha256"] is None): raise Bad(f"5: species {s['name']!r}: leafless_texel without leafless_sha256 or the reverse")
        for series, vals in (("foliage", lambda k: k["albedo"]), ("leaf_fraction", lambda k: [k["value"]])):
            keys = s[series]
            if not keys: raise Bad(f"6: species {s['name']!r}: empty {series}")
            if any(not 1 <= k["day"] <= 366 for k in keys): raise Bad(f"6: species {s['name']!r}: {series} day outside 1..366")
            if any(not a["day"] < b["day"] for a, b in zip(keys, keys[1:])): raise Bad(f"6: species {s['name']!r}: {series} days not increasing")
            if any(not 0 <= v <= 1 for k in keys for v in vals(k)): raise Bad(f"6: species {s['name']!r}: {series} value outside [0, 1]")
    if minor >= 1:  # 1.1: the heightmap conversion after count
        h["heightmap"] = {"size": c.option(lambda: c.f64s(2)), "height_range": c.option(lambda: c.f64s(2))}
    if not h["terrain"]: raise Bad("7: no terrain source")
    if h["count"] > 113_025_455: raise Bad(f"8: count {h['count']} above 113,025,455")
    if 19 * h["count"] != R: raise Bad(f"8: 19 x count = {19 * h['count']}, R = {R}")
    hm = h.get("heightmap")
    if hm and hm["size"] is not None and not all(math.isfinite(v) and v > 0 for v in hm["size"]):
        raise Bad(f"10: heightmap size {hm['size']} not two positive finite extents")
    if hm and hm["height_range"] is not None and not (all(map(math.isfinite, hm["height_range"])) and hm["height_range"][0] < hm["height_range"][1]):
        raise Bad(f"10: heightmap height_range {hm['height_range']} needs finite LO < HI")
    if h["count"] > TREE_LIMIT: raise Bad(f"{h['count']} trees, more than this reader's limit of {TREE_LIMIT}")
    return h

def planes(b, n, w):  # byte planes of n little-endian w-byte values
    return [sum(b[k * n + i] << (8 * k) for k in range(w)) for i in range(n)]

def read_instances_payload(h, p):
    n, cols, pos = h["count"], {}, 0
    for name, w in (("x", 4), ("z", 4), ("y", 4), ("species", 1), ("rotation", 2), ("scale", 2), ("variation", 2)):
        cols[name] = planes(p[pos:pos + w * n], n, w)
        pos += w * n
    for axis in "xzy":
        q, qs, ds = 0, [], []
        for v in cols[axis]:
            d = (v >> 1) ^ (-(v & 1) & 0xFFFFFFFF)                 # un-zigzag, as u32
            q = (q + d) & 0xFFFFFFFF                                  # wrap modulo 2^32
            qs.append(q - (1 << 32) if q >> 31 else q)
            ds.append(d - (1 << 32) if d >> 31 else d)
        cols[axis], cols["d" + axis] = qs, ds
    for i, s in enumerate(cols["species"]):
        if s >= len(h["species"]): raise Bad(f"9: tree {i} names species {s}, the table has {len(h['species'])}")
    h["trees"] = cols

def instances_summary(h, limit=20):
    o, t = h["origin"], h["trees"]
    print(f"  generator {h['generator']!r}; seed {h['seed']}; region {h['region']}; raster_cell {h['raster_cell']}; max_count {h['max_count']}, truncated {h['truncated']}")
    print(f"  terrain {[s['path'] for s in h['terrain']]}; species_file {h['species_file']['path']}; origin {o}")
    if "heightmap" in h: print(f"  heightmap size {h['heightmap']['size']}, height_range {h['heightmap']['height_range']}")
    for i, s in enumerate(h["species"]):
        print(f"  species {i} {s['name']!r}: texel {s['texel']}, leafless {s['leafless_texel']}, model_height {s['model_height']}, spacing {s['spacing']}, "
              f"height {s['height_min']}..{s['height_max']}, traits {s['traits']}, {len(s['foliage'])} foliage / {len(s['leaf_fraction'])} leaf keys")
    print(f"  {h['count']} trees (x, z, y cm from origin; species; rotation, scale, variation codes; world x, y, z m, turns, scale):")
    for i in range(min(h["count"], limit)):
        print(f"  {i:4} {t['x'][i]:>12} {t['z'][i]:>10} {t['y'][i]:>8}  {t['species'][i]:3}  {t['rotation'][i]:5} {t['scale'][i]:5} {t['variation'][i]:5}"
              f"   ({o[0] + 0.01 * t['x'][i]:.2f}, {o[1] + 0.01 * t['y'][i]:.2f}, {o[2] + 0.01 * t['z'][i]:.2f}) {t['rotation'][i] / 65536:.4f} {2 ** ((t['scale'][i] - 32768) / 2048):.4f}")

# ---------------------------------------------------------------- golden values (texel.md and instances.md, "Golden file")
def check_golden(h):
    bad = []
    def eq(what, got, want):
        if got != want: bad.append(f"{what}: decoded {got!r}, spec says {want!r}")
    name = os.path.basename(h["path"])
    if name == "conifer-8.texel":
        eq("size", h["size"], 11888); eq("SHA-256", (h["sha256"][:8], h["sha256"][-8:]), ("4ea83ae4", "b737261b"))
        eq("version, H, R, P", (h["version"], h["H"], h["R"], h["P"]), ((1, 7), 2322, 23520, 9530))
        eq("generator", h["generator"], "texel-forest 0.1.0")
        eq("density_model, extinction_scale", (h["density_model"], h["extinction_scale"]), ("Transmittance", 1.0))
        eq("triangles, foliage_triangles", (h["triangles"], h["foliage_triangles"]), (9634, 4698))
        eq("parameters", h["parameters"], {"resolution": 8, "fine": 32, "foliage_pattern": "leaf|leaves|foliage|needle|crown", "requested_gamma": None})
        eq("wood_pattern", h["wood_pattern"], None)
        eq("materials", [(m["name"], m["reason"], m["cut"], m["triangles"]) for m in h["materials"]], [("bark", "Solid", 0.0, 4936), ("needles", "FoliagePattern", 0.0, 4698)])
        eq("level dims", [l["dims"] for l in h["levels"]], [[5, 8, 5], [3, 4, 3], [2, 2, 2], [1, 1, 1]])
        eq("level 0 cell", h["levels"][0]["cell"], 1.7749999286606908); eq("level 3 cell", h["levels"][3]["cell"], 14.199999429285526)
        d0, d3 = h["data"][0], h["data"][3]
        eq("level 0 density sums (6 decimals)", [round(math.fsum(d0[k]), 6) for k in ("density_wood", "density_foliage")], [3.031733, 12.003606])
        eq("level 3 densities (binary32)", [d3["density_wood"][0], d3["density_foliage"][0]], [f32(0.004592287), f32(0.01124059)])
        v = cell_values(h, 0, 2, 4, 2)
        eq("cell (2,4,2) densities (binary32)", v["density_wood"] + v["density_foliage"], [f32(0.14124848), f32(0.95244324)])
        eq("cell (2,4,2) gradient_foliage (binary32)", v["gradient_foliage"], [f32(0.0049794232), f32(-0.09594187), f32(-0.0043856315)])
        eq("cell (2,4,2) albedo_foliage (n/65535 as binary32)", [f32(a) for a in v["albedo_foliage"]], [f32(0.018005647), f32(0.050003815), f32(0.02200351)])
        eq("cell (2,4,2) leaves_foliage (binary32)", v["leaves_foliage"], [f32(x) for x in (0.31541827, 0.4506226, 0.23395924, -0.016198598, -0.0015631133, 0.007044819)])
        eq("cell (2,4,2) normals_wood (binary32)", v["normals_wood"], [f32(x) for x in (0.12878546, 0.63163596, 0.23957855, 0.04518614, 0.07614372, -0.08231792)])
        D = h["directional"]
        eq("directional, level 0 (binary32)", D[0], [f32(x) for x in (0.97833616, 0.9298298, 0.79578304, -0.03858423, -0.029057113, -0.023108635, -0.012949278)])
        eq("directional, level 3 (binary32)", D[3], [f32(x) for x in (1.0950726, 0.51435393, 1.0293595, -0.0055540637, -0.00496657, -0.0027240135, -0.1227481)])
        K = h["self_shadow"]
        eq("self_shadow, level 0 (binary32)", K[0], [f32(x) for x in (0, 0.785534, 1.46424, 3.7845263, 11.721015, 11.721015)])
        eq("self_shadow, level 3 (binary32)", K[3], [f32(x) for x in (0, 4.3975983, 7.681765, 16, 16, 16)])
        KH = h["self_shadow_by_height"][0]
        eq("self_shadow_by_height, level 0, sun 0 degrees high (binary32)", KH[0], [f32(x) for x in (0, 0.60269356, 1.1828158, 2.744933, 6.5630956, 6.5630956)])
        eq("self_shadow_by_height, level 0, sun 90 degrees high (binary32)", KH[3], [f32(x) for x in (0, 1.0867108, 1.8013058, 5.8963995, 16, 16)])
        KV = h["self_shadow_by_view"][0]
        eq("self_shadow_by_view, level 0, eye 35 degrees high, sun turned 0 (binary32)", KV[1][0], [f32(x) for x in (0, 0.7995272, 1.5933199, 5.214918, 16, 16)])
        eq("self_shadow_by_view, level 0, eye 60 degrees high, sun turned 180 (binary32)", KV[2][2], [f32(x) for x in (0, 0.92139345, 1.6098866, 5.9532695, 11.721015, 11.721015)])
        eq("wood_weight, levels 0 and 3 (binary32)", [h["wood_weight"][0], h["wood_weight"][3]], [f32(0.31840825), f32(0.22947289)])
        eq("shown_wood, cell (2,4,2) of level 0 and level 3 (binary32)", [v["shown_wood"][0], d3["shown_wood"][0]], [f32(0.0847375), f32(0.0012333298)])
        eq("k_0 along y and along the body diagonal (6 decimals)", [round(directional_factor(D[0], w), 6) for w in ((0, 1, 0), (1, 1, 1))], [0.957539, 0.914604])
    elif name == "forest-12.instances":
        eq("size", h["size"], 1120); eq("SHA-256", (h["sha256"][:8], h["sha256"][-8:]), ("dcb70327", "b8048eac"))
        eq("version, H, R, P", (h["version"], h["H"], h["R"], h["P"]), ((1, 0), 910, 228, 174))
        eq("species (name, has leafless)", [(s["name"], s["leafless_texel"] is not None) for s in h["species"]], [("beech", True), ("red pine", False)])
        eq("count", h["count"], 12); eq("origin", h["origin"], [-1000.0, 120.0, -2000.0])
        t = h["trees"]
        for i, want in {0: (0, 0, 0, 0, 0, 32768, 0), 1: (350, 120, 15, 1, 16384, 32109, 1), 3: (1050, 400, -20, 1, 65535, 30720, 7),
                        7: (-1200, -600, -400, 1, 24576, 33050, 3), 9: (2100000000, 5, 0, 1, 100, 32768, 5),
                        10: (-2100000000, 5, 0, 0, 200, 32768, 6)}.items():
            eq(f"tree {i}", tuple(t[k][i] for k in ("x", "z", "y", "species", "rotation", "scale", "variation")), want)
        eq("tree 10 x delta", t["dx"][10], 94_967_296)
    elif name == "forest-12-heightmap.instances":
        eq("version", h["version"], (1, 1))
        eq("terrain", [s["path"] for s in h["terrain"]], ["terrain/valley.png"])
        eq("heightmap", h["heightmap"], {"size": [2000.0, 2000.0], "height_range": [-12.5, 480.5]})
        eq("count", h["count"], 12); eq("tree 10 x delta", h["trees"]["dx"][10], 94_967_296)
    else:
        bad.append("no golden values for this file name")
    return bad

def main(argv):
    golden, invalid = "--check-golden" in argv, "--expect-invalid" in argv
    files = [a for a in argv if not a.startswith("--")]
    if not files or len(files) + golden + invalid != len(argv):
        print(__doc__.strip().splitlines()[-1]); return 2
    failed = False
    for path in files:
        try:
            h = read_file(path)
        except (Bad, OSError) as e:
            print(f"{path}: {'REFUSED (as expected)' if invalid else 'INVALID'}: {e}")
            failed |= not invalid
            continue
        h["path"] = path
        print(f"{path}: {'ACCEPTED, but expected invalid' if invalid else 'valid'} .{h['fmt']} {h['version'][0]}.{h['version'][1]}, H {h['H']}, R {h['R']}, P {h['P']}")
        failed |= invalid
        (texel_summary if h["fmt"] == "texel" else instances_summary)(h)
        if golden:
            diffs = check_golden(h)
            for d in diffs: print(f"  GOLDEN MISMATCH {d}")
            print(f"  golden values: {'MISMATCH' if diffs else 'all match'}")
            failed |= bool(diffs)
    return 1 if failed else 0

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
