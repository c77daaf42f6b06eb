"""What Blender (3.4, headless) makes of chisel's outputs, one line per check.

usage: blender -b --factory-startup --python blender_check.py -- CHECK...
  mesh:PATH            import an OBJ, PLY or glTF binary (.glb) as Blender's
                       importer gives it (nothing merged); prints
                       `MESH PATH faces F boundary B nonmanifold N uv U
                        welded_faces WF welded_boundary WB welded_nonmanifold WN`
                       (B: edges with one face, N: with more than two;
                       U: UV layers; W*: the same once vertices at
                       bit-identical coordinates are one and the faces left
                       with fewer than 3 corners dropped)
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
  export:SRC:DST       import the OBJ SRC and export it as glTF 2.0 (DST .glb:
                       binary; .gltf: JSON with a .bin beside it), as a user
                       of a real-time engine would hand chisel a base mesh;
                       prints `EXPORT DST`
  scene:GLB:OBJ        a scene glTF has to get right, written both as .glb and
                       as Blender's OBJ (its transforms applied): a
                       UV-unwrapped monkey with two materials (two
                       primitives), and the same mesh again (one mesh, two
                       nodes) mirrored under a rotated, moved and scaled
                       parent; prints `SCENE GLB`
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
    else:
        bpy.ops.wm.obj_import(filepath=path)
    new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    return new[0]


def topology(me, weld):
    """Faces, edges with one face and edges with more than two.

    weld: vertices at bit-identical coordinates count as one. glTF keeps
    one vertex per (position, normal, UV) (glTF 2.0 3.7.2.1), so a .glb
    is split along creases, walls and seams; this joins exactly those
    copies back and nothing else. Merge by Distance (bmesh remove_doubles)
    does not: it merges nothing at distance 0 and missed most exact
    duplicates at 1e-9, and at 1e-7 it also collapsed the mesh's own
    edges shorter than that (the OBJ's too)."""
    import numpy as np
    nv, nl, nf = len(me.vertices), len(me.loops), len(me.polygons)
    co = np.empty(3 * nv, np.float32)
    me.vertices.foreach_get("co", co)
    v = np.empty(nl, np.int32)
    me.loops.foreach_get("vertex_index", v)
    start = np.empty(nf, np.int32)
    total = np.empty(nf, np.int32)
    me.polygons.foreach_get("loop_start", start)
    me.polygons.foreach_get("loop_total", total)
    if weld and nv:
        _, ids = np.unique(co.reshape(-1, 3), axis=0, return_inverse=True)
        v = ids.reshape(-1)[v]
    face = np.repeat(np.arange(nf), total)  # each loop's polygon
    nxt = np.arange(nl) + 1
    last = start + total - 1
    nxt[last] = start  # each polygon's last loop closes on its first
    a, b = v, v[nxt]
    # A polygon keeps a corner per distinct vertex (a collapsed loop is
    # dropped, as merging does), and counts while 3 remain.
    corners = np.bincount(face, weights=(a != b), minlength=nf)
    kept = corners >= 3
    live = (a != b) & kept[face]
    edges = np.sort(np.stack([a[live], b[live]], axis=1), axis=1)
    if len(edges):
        _, users = np.unique(edges, axis=0, return_counts=True)
    else:
        users = np.zeros(0, np.int64)
    return int(kept.sum()), int((users == 1).sum()), int((users > 2).sum())


def check_mesh(path):
    me = import_mesh(path).data
    faces, boundary, nonmanifold = topology(me, False)
    wfaces, wboundary, wnonmanifold = topology(me, True)
    print("MESH %s faces %d boundary %d nonmanifold %d uv %d welded_faces %d welded_boundary %d welded_nonmanifold %d" %
          (path, faces, boundary, nonmanifold, len(me.uv_layers), wfaces, wboundary, wnonmanifold), flush=True)


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


def export_gltf(src, dst):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=src)
    fmt = "GLB" if dst.lower().endswith(".glb") else "GLTF_SEPARATE"
    bpy.ops.export_scene.gltf(filepath=dst, export_format=fmt)
    print("EXPORT %s" % dst, flush=True)


def export_scene(glb, obj):
    import math
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add(size=1.0)
    a = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(island_margin=0.02)
    bpy.ops.object.mode_set(mode="OBJECT")
    for name in ("m0", "m1"):
        a.data.materials.append(bpy.data.materials.new(name))
    for i, p in enumerate(a.data.polygons):
        p.material_index = i % 2
    parent = bpy.data.objects.new("parent", None)
    bpy.context.scene.collection.objects.link(parent)
    parent.location, parent.rotation_euler, parent.scale = (3, 1, 0.5), (0.3, 0.2, 1.1), (1.5, 1.5, 1.5)
    twin = bpy.data.objects.new("twin", a.data)
    bpy.context.scene.collection.objects.link(twin)
    twin.parent, twin.location, twin.scale = parent, (1, 0, 0), (-1, 1, 1)
    bpy.context.view_layer.update()
    bpy.ops.export_scene.gltf(filepath=glb, export_format="GLB")
    bpy.ops.wm.obj_export(filepath=obj, export_materials=False)
    print("SCENE %s" % glb, flush=True)


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
        elif kind == "scene":
            export_scene(parts[0], parts[1])
        elif kind == "export":
            export_gltf(parts[0], parts[1])
        else:
            print("UNKNOWN %s" % a, flush=True)


main(sys.argv[sys.argv.index("--") + 1:])
