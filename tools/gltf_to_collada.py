#!/usr/bin/env python3
"""Writes a skinned, animated glTF binary (one mesh, one primitive, one skin, one animation, as
`amhv import-bvh --body skinned` writes character.glb) as Collada 1.4.1: the mesh, its skin (the
glTF's inverse bind matrices, its four weights per vertex), the node hierarchy, and each animated
node's local transform per key as a matrix channel (`NODE/transform`), the layout Blender writes
and assimp reads.

    python3 tools/gltf_to_collada.py IN.glb OUT.dae

Made for data/characters/cmu_18_01.dae (data/characters/README.md says why not Blender's own
Collada export). Only the Python standard library."""
import json
import math
import struct
import sys


def read_glb(path):
    data = open(path, "rb").read()
    magic, _, _ = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF":
        sys.exit(f"{path}: not a glTF binary")
    json_length, = struct.unpack_from("<I", data, 12)
    gltf = json.loads(data[20:20 + json_length])
    binary_at = 20 + json_length
    binary = data[binary_at + 8:] if binary_at < len(data) else b""
    return gltf, binary


def accessor(gltf, binary, index):
    a = gltf["accessors"][index]
    view = gltf["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[a["type"]]
    fmt = {5126: "f", 5123: "H", 5121: "B", 5125: "I"}[a["componentType"]]
    size = struct.calcsize(fmt)
    stride = view.get("byteStride", width * size)
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return [list(struct.unpack_from("<" + fmt * width, binary, start + i * stride)) for i in range(a["count"])]


def matrix_trs(t, r, s):
    x, y, z, w = r
    rot = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
           [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
           [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return [[rot[i][0] * s[0], rot[i][1] * s[1], rot[i][2] * s[2], t[i]] for i in range(3)] + [[0, 0, 0, 1]]


def node_matrix(node):
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    return matrix_trs(node.get("translation", [0, 0, 0]), node.get("rotation", [0, 0, 0, 1]), node.get("scale", [1, 1, 1]))


def numbers(values):
    return " ".join(f"{v:.9g}" for v in values)


def rows(m):
    return numbers(v for row in m for v in row)


def source(ident, values, stride, param, kind="float"):
    array = "Name_array" if kind == "name" else "float_array"
    count = len(values) // stride
    text = " ".join(values) if kind == "name" else numbers(values)
    return (f'<source id="{ident}"><{array} id="{ident}-array" count="{len(values)}">{text}</{array}>'
            f'<technique_common><accessor source="#{ident}-array" count="{count}" stride="{stride}">'
            f'<param name="{param}" type="{"float4x4" if stride == 16 else kind}"/></accessor></technique_common></source>')


def animations(gltf, binary, names):
    """Per animated node, one matrix channel over the union of its channels' key times."""
    anim = gltf["animations"][0]
    by_node = {}
    for channel in anim["channels"]:
        sampler = anim["samplers"][channel["sampler"]]
        times = [t[0] for t in accessor(gltf, binary, sampler["input"])]
        values = accessor(gltf, binary, sampler["output"])
        by_node.setdefault(channel["target"]["node"], {})[channel["target"]["path"]] = dict(zip(times, values))
    out = []
    for node, paths in sorted(by_node.items()):
        rest = gltf["nodes"][node]
        times = sorted(set(t for keys in paths.values() for t in keys))
        matrices = []
        for t in times:
            trs = [paths.get(p, {}).get(t, rest.get(p, d)) for p, d in
                   (("translation", [0, 0, 0]), ("rotation", [0, 0, 0, 1]), ("scale", [1, 1, 1]))]
            matrices += [v for row in matrix_trs(*trs) for v in row]
        name = names[node]
        out.append(f'<animation id="{name}-anim">' + source(f"{name}-input", times, 1, "TIME")
                   + source(f"{name}-output", matrices, 16, "TRANSFORM")
                   + source(f"{name}-interpolation", ["LINEAR"] * len(times), 1, "INTERPOLATION", "name")
                   + f'<sampler id="{name}-sampler"><input semantic="INPUT" source="#{name}-input"/>'
                   f'<input semantic="OUTPUT" source="#{name}-output"/><input semantic="INTERPOLATION" source="#{name}-interpolation"/></sampler>'
                   f'<channel source="#{name}-sampler" target="{name}/transform"/></animation>')
    return out


def main():
    src, dst = sys.argv[1:3]
    gltf, binary = read_glb(src)
    names = [n.get("name", f"node{i}") for i, n in enumerate(gltf["nodes"])]
    skin = gltf["skins"][0]
    joints = skin["joints"]
    mesh_node = next(i for i, n in enumerate(gltf["nodes"]) if "mesh" in n)
    primitive = gltf["meshes"][gltf["nodes"][mesh_node]["mesh"]]["primitives"][0]
    positions = accessor(gltf, binary, primitive["attributes"]["POSITION"])
    indices = [i[0] for i in accessor(gltf, binary, primitive["indices"])]
    vertex_joints = accessor(gltf, binary, primitive["attributes"]["JOINTS_0"])
    vertex_weights = accessor(gltf, binary, primitive["attributes"]["WEIGHTS_0"])
    inverse_binds = accessor(gltf, binary, skin["inverseBindMatrices"])  # column-major
    weights, vcount, v = [], [], []
    for js, ws in zip(vertex_joints, vertex_weights):
        pairs = [(j, w) for j, w in zip(js, ws) if w > 0]
        vcount.append(len(pairs))
        for j, w in pairs:
            v += [j, len(weights)]
            weights.append(w)
    mesh = (f'<geometry id="body-mesh" name="body"><mesh>' + source("body-positions", [c for p in positions for c in p], 3, "X")
            .replace('<param name="X" type="float"/>', '<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>')
            + '<vertices id="body-vertices"><input semantic="POSITION" source="#body-positions"/></vertices>'
            f'<triangles count="{len(indices) // 3}"><input semantic="VERTEX" source="#body-vertices" offset="0"/><p>{" ".join(map(str, indices))}</p></triangles>'
            '</mesh></geometry>')
    binds = [m[c * 4 + r] for m in inverse_binds for r in range(4) for c in range(4)]
    controller = ('<controller id="body-skin"><skin source="#body-mesh"><bind_shape_matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1</bind_shape_matrix>'
                  + source("body-joints", [names[j] for j in joints], 1, "JOINT", "name") + source("body-binds", binds, 16, "TRANSFORM")
                  + source("body-weights", weights, 1, "WEIGHT")
                  + '<joints><input semantic="JOINT" source="#body-joints"/><input semantic="INV_BIND_MATRIX" source="#body-binds"/></joints>'
                  f'<vertex_weights count="{len(positions)}"><input semantic="JOINT" source="#body-joints" offset="0"/>'
                  f'<input semantic="WEIGHT" source="#body-weights" offset="1"/><vcount>{" ".join(map(str, vcount))}</vcount>'
                  f'<v>{" ".join(map(str, v))}</v></vertex_weights></skin></controller>')
    joint_set = set(joints)

    def node_xml(i):
        n = gltf["nodes"][i]
        kind = "JOINT" if i in joint_set else "NODE"
        body = f'<matrix sid="transform">{rows(node_matrix(n))}</matrix>'
        if i == mesh_node:
            body += f'<instance_controller url="#body-skin"><skeleton>#{names[joints[0]]}</skeleton></instance_controller>'
        body += "".join(node_xml(c) for c in n.get("children", []))
        return f'<node id="{names[i]}" name="{names[i]}" sid="{names[i]}" type="{kind}">{body}</node>'

    roots = gltf["scenes"][gltf.get("scene", 0)]["nodes"]
    with open(dst, "w") as out:
        out.write('<?xml version="1.0" encoding="utf-8"?>\n<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">\n'
                  '<asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>\n'
                  f'<library_geometries>{mesh}</library_geometries>\n<library_controllers>{controller}</library_controllers>\n'
                  f'<library_animations>{"".join(animations(gltf, binary, names))}</library_animations>\n'
                  f'<library_visual_scenes><visual_scene id="Scene" name="Scene">{"".join(node_xml(r) for r in roots)}</visual_scene></library_visual_scenes>\n'
                  '<scene><instance_visual_scene url="#Scene"/></scene>\n</COLLADA>\n')


if __name__ == "__main__":
    main()
