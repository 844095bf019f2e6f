#!/usr/bin/env python3
"""Writes a small seed GLB from a large one: keeps every k-th triangle of each primitive (at
most --triangles of them), only the vertices those use, and the same nodes and materials.
Handles what the procedural fixtures hold: float attributes, unsigned indices, one buffer.

    python3 fuzz/shrink_glb.py fixtures/trees/conifer.glb corpus/gltf/conifer-small.glb
"""
import argparse, json, struct

CT = {5120: 'b', 5121: 'B', 5122: 'h', 5123: 'H', 5125: 'I', 5126: 'f'}
N = {'SCALAR': 1, 'VEC2': 2, 'VEC3': 3, 'VEC4': 4}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('src')
    ap.add_argument('dst')
    ap.add_argument('--triangles', type=int, default=120)
    a = ap.parse_args()
    b = open(a.src, 'rb').read()
    jl = struct.unpack_from('<I', b, 12)[0]
    doc = json.loads(b[20:20 + jl])
    bin_at = 20 + jl
    bl = struct.unpack_from('<I', b, bin_at)[0]
    blob = b[bin_at + 8:bin_at + 8 + bl]

    def read(i):
        acc = doc['accessors'][i]
        v = doc['bufferViews'][acc['bufferView']]
        n = N[acc['type']]
        fmt = CT[acc['componentType']]
        size = struct.calcsize(fmt)
        stride = v.get('byteStride', size * n)
        base = v.get('byteOffset', 0) + acc.get('byteOffset', 0)
        return [list(struct.unpack_from('<%d%s' % (n, fmt), blob, base + e * stride))
                for e in range(acc['count'])]

    out = bytearray()
    views, accessors = [], []

    def add(values, ty, ct):
        while len(out) % 4:
            out.append(0)
        fmt = CT[ct]
        data = b''.join(struct.pack('<%d%s' % (len(e), fmt), *e) for e in values)
        views.append({'buffer': 0, 'byteOffset': len(out), 'byteLength': len(data)})
        out.extend(data)
        acc = {'bufferView': len(views) - 1, 'componentType': ct, 'count': len(values), 'type': ty}
        if ty == 'VEC3' and ct == 5126:
            acc['min'] = [min(e[c] for e in values) for c in range(3)]
            acc['max'] = [max(e[c] for e in values) for c in range(3)]
        accessors.append(acc)
        return len(accessors) - 1

    for mesh in doc['meshes']:
        for p in mesh['primitives']:
            idx = [e[0] for e in read(p['indices'])]
            tris = [idx[i:i + 3] for i in range(0, len(idx) - 2, 3)]
            k = max(1, len(tris) // a.triangles)
            tris = tris[::k][:a.triangles]
            used = sorted({v for t in tris for v in t})
            remap = {v: i for i, v in enumerate(used)}
            attrs = {}
            for name, ai in p['attributes'].items():
                vals = read(ai)
                acc = doc['accessors'][ai]
                attrs[name] = add([vals[v] for v in used], acc['type'], acc['componentType'])
            p['attributes'] = attrs
            p['indices'] = add([[remap[v]] for t in tris for v in t], 'SCALAR', 5123)
    while len(out) % 4:
        out.append(0)
    doc['accessors'], doc['bufferViews'] = accessors, views
    doc['buffers'] = [{'byteLength': len(out)}]
    j = json.dumps(doc, separators=(',', ':')).encode()
    j += b' ' * (-len(j) % 4)
    total = 12 + 8 + len(j) + 8 + len(out)
    glb = b'glTF' + struct.pack('<II', 2, total) + struct.pack('<II', len(j), 0x4E4F534A) + j \
        + struct.pack('<II', len(out), 0x004E4942) + bytes(out)
    open(a.dst, 'wb').write(glb)
    print(a.dst, len(glb), 'bytes')


main()
