"""What Blender (3.4, headless) makes of chisel's outputs, one line per check.

usage: blender -b --factory-startup --python blender_check.py -- CHECK...
  mesh:PATH            import an OBJ, PLY or glTF binary (.glb); prints
                       `MESH PATH faces F boundary B nonmanifold N uv U`
                       (B: edges with one face; U: UV layers)
  image:PATH:X:Y       load an image as a user would (Non-Color); prints
                       `IMAGE PATH type T size W H value V` with V the first
                       channel of pixel (X, Y), Y counted from the top row
  passes:PATH          the layers and passes of a multilayer EXR as the
                       compositor's Image node offers them; prints
                       `PASSES PATH type T name name ...`
  displace:BASE:MAP:MID:STRENGTH:LEVELS
                       the README's route: BASE subdivided (Simple, LEVELS),
                       a Displace modifier along the normals with MAP through
                       the UVs; prints `DISPLACE MAP zmin Z0 zmax Z1` of the
                       evaluated mesh
"""
import sys

import bpy


def import_mesh(path):
    before = set(bpy.data.objects)
    if path.lower().endswith(".ply"):
        bpy.ops.import_mesh.ply(filepath=path)
    elif path.lower().endswith(".glb"):
        # Blender 3.4's importer still uses np.bool, which numpy 1.24
        # (Debian 12) removed: alias it back for the import.
        import numpy
        if not hasattr(numpy, "bool"):
            numpy.bool = bool
        bpy.ops.import_scene.gltf(filepath=path)
        new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
        # glTF stores a vertex per (position, UV, normal); "Merge by
        # distance" at float precision joins them back, as a user checking
        # watertightness would. Its faces with no area go with it.
        import bmesh
        bm = bmesh.new()
        bm.from_mesh(new[0].data)
        bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=1e-7)
        bm.to_mesh(new[0].data)
        bm.free()
        return new[0]
    else:
        bpy.ops.wm.obj_import(filepath=path)
    new = [o for o in bpy.data.objects if o not in before]
    return new[0]


def check_mesh(path):
    obj = import_mesh(path)
    me = obj.data
    users = {}
    for p in me.polygons:
        for key in p.edge_keys:
            users[key] = users.get(key, 0) + 1
    boundary = sum(1 for n in users.values() if n == 1)
    nonmanifold = sum(1 for n in users.values() if n > 2)
    print("MESH %s faces %d boundary %d nonmanifold %d uv %d" % (path, len(me.polygons), boundary, nonmanifold,
                                                                len(me.uv_layers)), flush=True)


def check_image(path, x, y):
    img = bpy.data.images.load(path)
    img.colorspace_settings.name = "Non-Color"
    w, h = img.size
    value = float("nan")
    if w and h and len(img.pixels):
        ch = img.channels
        row = h - 1 - y  # Blender's rows go up
        value = img.pixels[(row * w + x) * ch]
    print("IMAGE %s type %s size %d %d value %.9g" % (path, img.type, w, h, value), flush=True)


def check_passes(path):
    img = bpy.data.images.load(path)
    scene = bpy.context.scene
    scene.use_nodes = True
    node = scene.node_tree.nodes.new("CompositorNodeImage")
    node.image = img
    names = [o.name for o in node.outputs if o.enabled]
    print("PASSES %s type %s %s" % (path, img.type, " ".join(names)), flush=True)


def check_displace(base, image, mid, strength, levels):
    obj = import_mesh(base)
    bpy.context.view_layer.objects.active = obj
    sub = obj.modifiers.new("subdivide", "SUBSURF")
    sub.subdivision_type = "SIMPLE"
    sub.levels = int(levels)
    img = bpy.data.images.load(image)
    img.colorspace_settings.name = "Non-Color"
    tex = bpy.data.textures.new("height", type="IMAGE")
    tex.image = img
    tex.extension = "EXTEND"
    tex.use_clamp = False  # values outside [0, 1] (a raw float map) stay as they are
    disp = obj.modifiers.new("displace", "DISPLACE")
    disp.texture = tex
    disp.texture_coords = "UV"
    disp.direction = "NORMAL"
    disp.mid_level = float(mid)
    disp.strength = float(strength)
    deps = bpy.context.evaluated_depsgraph_get()
    me = obj.evaluated_get(deps).to_mesh()
    zs = [v.co.z for v in me.vertices]
    print("DISPLACE %s zmin %.9g zmax %.9g" % (image, min(zs), max(zs)), flush=True)


def main(args):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for a in args:
        kind, _, rest = a.partition(":")
        parts = rest.split(":")
        if kind == "mesh":
            check_mesh(rest)
        elif kind == "image":
            check_image(parts[0], int(parts[1]), int(parts[2]))
        elif kind == "passes":
            check_passes(rest)
        elif kind == "displace":
            check_displace(*parts)
        else:
            print("UNKNOWN %s" % a, flush=True)


main(sys.argv[sys.argv.index("--") + 1:])
