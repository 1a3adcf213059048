# Imports a BVH file with Blender's own importer and writes every bone's
# head position (world frame, metres) per frame as JSON, for test_take:
#   blender -b --factory-startup --python blender_bvh.py -- IN.bvh OUT.json
# The axes are left as the file has them (forward Y, up Z: no conversion)
# and centimetres are scaled to metres.
import builtins
import json
import sys

import bpy

# Debian's Blender 3.4 importer opens files with mode 'rU', which Python
# 3.11 no longer takes: give its module an open() without the 'U'.
import io_anim_bvh.import_bvh as _importer  # noqa: E402

_importer.open = lambda path, mode="r", *a, **k: builtins.open(path, mode.replace("U", ""), *a, **k)

bvh, out = sys.argv[sys.argv.index("--") + 1:][:2]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=bvh, global_scale=0.01, axis_forward="Y", axis_up="Z",
                        rotate_mode="NATIVE", update_scene_fps=False, update_scene_duration=True,
                        use_fps_scale=False)
scene = bpy.context.scene
armature = next(o for o in scene.objects if o.type == "ARMATURE")
first, last = (int(round(x)) for x in armature.animation_data.action.frame_range)
frames = []
for f in range(first, last + 1):
    scene.frame_set(f)
    frames.append({b.name: list(armature.matrix_world @ b.head) for b in armature.pose.bones})
with open(out, "w") as fp:
    json.dump(frames, fp)
