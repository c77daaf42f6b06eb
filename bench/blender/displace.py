"""What a Blender user does to carve a height map into a mesh, timed:
import the base OBJ, subdivide it (edit-mode cuts, then a Subdivision
Surface modifier, Simple, which keeps the base surface as chisel's bilinear
scheme does) to about the requested triangle count, displace it along the
normals with the height map through the UVs (Displace modifier), export the
triangulated result as OBJ.

usage: blender -b --factory-startup --python displace.py -- BASE.obj HEIGHT.exr OUT.obj TARGET_TRIANGLES \
         STRENGTH MIDLEVEL       (HEIGHT.exr, STRENGTH and MIDLEVEL from height_to_y.py)
Prints one line: `blender: triangles N import S subdivide S displace+export S total S`.
"""
import sys
import time

import bpy

t_start = time.perf_counter()
base, height, out, target, strength, midlevel = sys.argv[sys.argv.index("--") + 1:][:6]
target = int(target)

bpy.ops.wm.read_factory_settings(use_empty=True)
t0 = time.perf_counter()
bpy.ops.wm.obj_import(filepath=base)
obj = bpy.context.selected_objects[0]
bpy.context.view_layer.objects.active = obj
t1 = time.perf_counter()

# Cuts c and levels L: quads become 2 (c + 1)^2 4^L triangles. The
# deepest L within 5% of the target (fewer edit-mode cuts, as users do).
quads = sum(1 for p in obj.data.polygons if len(p.vertices) == 4)
tris = sum(1 for p in obj.data.polygons if len(p.vertices) == 3)
if tris or quads != len(obj.data.polygons):
    sys.exit("displace.py: %s: only all-quad bases are supported" % base)
best = None
for levels in range(0, 7):
    for cuts in range(0, 101):
        n = 2 * quads * (cuts + 1) ** 2 * 4 ** levels
        miss = abs(n - target) / target
        key = (miss > 0.05, -levels if miss <= 0.05 else miss, miss)
        if best is None or key < best[0]:
            best = (key, cuts, levels, n)
_, cuts, levels, expect = best
if cuts:
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
if levels:
    sub = obj.modifiers.new("subdivide", "SUBSURF")
    sub.subdivision_type = "SIMPLE"
    sub.levels = levels
    sub.render_levels = levels
    sub.uv_smooth = "NONE"
t2 = time.perf_counter()

img = bpy.data.images.load(height)
img.colorspace_settings.name = "Non-Color"
tex = bpy.data.textures.new("height", type="IMAGE")
tex.image = img
tex.extension = "EXTEND"
disp = obj.modifiers.new("displace", "DISPLACE")
disp.texture = tex
disp.texture_coords = "UV"
disp.direction = "NORMAL"
disp.strength = float(strength)
disp.mid_level = float(midlevel)
bpy.ops.wm.obj_export(filepath=out, export_selected_objects=True, apply_modifiers=True,
                      export_triangulated_mesh=True, export_materials=False, export_uv=True,
                      export_normals=True)
t3 = time.perf_counter()
print("blender: triangles %d cuts %d levels %d import %.3f subdivide %.3f displace+export %.3f total %.3f"
      % (expect, cuts, levels, t1 - t0, t2 - t1, t3 - t2, t3 - t_start), flush=True)
