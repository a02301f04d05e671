# Converts an amhv character (glTF, as `amhv import-bvh --body skinned` writes it) to FBX with Blender,
# keeping every frame of its animation (data/characters/README.md says how the shipped one was made):
#   blender -b --factory-startup --python tools/convert_character.py -- IN.glb OUT_STEM FPS
import sys
import numpy
numpy.bool = bool  # Debian 12's Blender 3.4 glTF importer still uses the removed alias
import bpy

src, stem, fps = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = int(fps)
bpy.ops.import_scene.gltf(filepath=src)
action = bpy.data.actions[0]
scene.frame_start, scene.frame_end = int(action.frame_range[0]), int(action.frame_range[1])
print("ACTION", action.name, scene.frame_start, scene.frame_end, scene.render.fps)
bpy.ops.export_scene.fbx(filepath=stem + ".fbx", bake_anim=True, add_leaf_bones=False, bake_anim_use_all_actions=False,
                         bake_anim_use_nla_strips=False, bake_anim_simplify_factor=0.0)
# Collada (bpy.ops.wm.collada_export) is not written: Blender 3.4 leaves out the animation of joints whose
# keys never change (this take's shoulders), so the arms come out 0.15 m off; tools/gltf_to_collada.py writes it.
