#!/usr/bin/env bash
# Imports a scene.glb into Blender headless (Debian's `blender`, 3.4; not installed by setup.sh:
# `apt-get install --no-install-recommends blender`) and prints the mesh object count, the
# animation's frame range in Blender frames and Blender's frame rate:
#
#   tools/blender_import.sh out/demo/scene.glb
#   blender: 566 mesh objects, 566 actions, frames 0.0..56.4 at 24 fps
#
# Shading is imported as "Smooth": Debian 12's Blender 3.4.1 glTF importer fails with its default
# ("Normals") on Debian's numpy 1.24 (it uses np.bool, removed in numpy 1.24); in the GUI choose
# Shading: Smooth (or Flat) in the import options.
set -euo pipefail
file="$(realpath "$1")"
blender -b --factory-startup --python-expr "
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath='$file', import_shading='SMOOTH')
meshes = [o for o in bpy.data.objects if o.type == 'MESH']
ranges = [a.frame_range[:] for a in bpy.data.actions]
first = min(r[0] for r in ranges) if ranges else 0
last = max(r[1] for r in ranges) if ranges else 0
print(f'blender: {len(meshes)} mesh objects, {len(ranges)} actions, frames {first:.1f}..{last:.1f} at {bpy.context.scene.render.fps} fps')
" 2>&1 | grep -E '^blender:|Error' 
