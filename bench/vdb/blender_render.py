"""Blender reads volga's OpenVDB files: import two .vdb files and render them.

Shows that a real OpenVDB client, Blender 5.0.1 (as the `bpy` Python module), reads
the `.vdb` files volga writes, with both value compressions:

* a narrow-band level set (grid `surface`, Blosc compression) of the Stanford bunny,
  meshed by Blender's Volume to Mesh modifier at iso value 0 and rendered as an
  opaque diffuse surface -> OUT/blender_level_set.png;
* an anti-aliased solid fog volume (grid `density`, zip compression) of the same
  bunny, rendered as smoke by a Principled Volume shader -> OUT/blender_fog.png.

Each file is imported into a fresh scene with `bpy.ops.object.volume_import`; the
script prints the grids Blender found (name, data type, load result) and raises if
the expected grid is missing, fails to load or (level set) meshes to nothing. Both
images are rendered by Cycles on the CPU (a minute or two on two cores).

Needs Blender as a Python module: `pip install bpy==5.0.1` (a CPython 3.11 wheel).
Run from the repository root:

    python bench/vdb/blender_render.py --volga target/release/volga --out docs/images/vdb

The .vdb files go to a temporary directory (or to DIR with --keep-vdb); only the
PNGs are written to DIR.
"""

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time

import bpy
import bmesh
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
MESH = os.path.join(REPO, "tests", "data", "stanford-bunny.obj")

RESOLUTION = 128  # voxels along the bunny's longest side (~0.155 world units)
IMAGE_SIZE = 480
SAMPLES = 48
FOG_DENSITY = 150.0  # per world unit; the bunny is ~0.15 units across


def make_vdbs(volga, vdb_dir):
    """Run volga to write the level set (Blosc) and the fog volume (zip)."""
    jobs = {
        "level_set": (
            os.path.join(vdb_dir, "bunny_level_set.vdb"),
            ["--distance", "3", "--vdb-compression", "blosc"],
        ),
        "fog": (
            os.path.join(vdb_dir, "bunny_fog.vdb"),
            ["--anti-aliased", "--solid", "--vdb-compression", "zip"],
        ),
    }
    paths = {}
    for kind, (path, extra) in jobs.items():
        cmd = [volga, "voxelize", MESH, "--resolution", str(RESOLUTION), *extra, "--out", path]
        print("$", " ".join(cmd), flush=True)
        result = subprocess.run(cmd, capture_output=True, text=True)
        sys.stdout.write(result.stdout)
        sys.stdout.write(result.stderr)
        if result.returncode != 0 or not os.path.isfile(path):
            raise SystemExit(f"volga failed (exit {result.returncode}) writing {path}")
        print(f"  {os.path.basename(path)}: {os.path.getsize(path)} bytes", flush=True)
        paths[kind] = path
    return paths


def import_volume(path, expected_grid):
    """Import a .vdb into a fresh scene; check and report its grids."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.object.volume_import(filepath=path)
    volumes = [o for o in bpy.context.scene.objects if o.type == "VOLUME"]
    if len(volumes) != 1:
        raise RuntimeError(f"{path}: expected one volume object, Blender made {len(volumes)}")
    vol = volumes[0]
    grids = vol.data.grids
    if not grids.load():
        raise RuntimeError(f"{path}: Blender could not read the file: {grids.error_message}")
    print(f"Blender imported {os.path.basename(path)} as object '{vol.name}' with {len(grids)} grid(s):")
    found = False
    for grid in grids:
        # VolumeGrid.load() reads the grid's tree and returns False on a read error;
        # is_loaded only says whether the tree is still cached at this moment.
        loaded = grid.load()
        print(
            f"  grid '{grid.name}': data type {grid.data_type}, {grid.channels} channel(s), "
            f"load() -> {loaded}, is_loaded {grid.is_loaded}",
            flush=True,
        )
        if grid.name == expected_grid:
            found = True
            if not loaded:
                raise RuntimeError(f"{path}: grid '{expected_grid}' failed to load")
    if not found:
        raise RuntimeError(f"{path}: no grid named '{expected_grid}'")
    # volga writes the mesh's own frame: the bunny is Y up; Blender is Z up.
    vol.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    bpy.context.view_layer.update()
    return vol


def world_bounds(obj):
    """World-space (min, max) corners of an object's evaluated bounding box."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    corners = [ev.matrix_world @ Vector(c) for c in ev.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    return lo, hi


def setup_stage(target, samples):
    """Cycles on the CPU, a camera on the bunny, sun + sky-ish world, a floor."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = True
    scene.render.resolution_x = IMAGE_SIZE
    scene.render.resolution_y = IMAGE_SIZE
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 100
    scene.view_settings.view_transform = "Standard"

    lo, hi = world_bounds(target)
    center = (lo + hi) / 2
    size = max(hi - lo)

    # World: a soft grey-blue fill, so nothing is black.
    # (In Blender 5, new worlds and materials come with node trees.)
    world = bpy.data.worlds.new("world")
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.55, 0.62, 0.75, 1.0)
    bg.inputs["Strength"].default_value = 0.4
    scene.world = world

    # Key light: a sun from the front right, above; the camera is front left.
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", type="SUN"))
    sun.data.energy = 4.0
    sun.data.angle = math.radians(10.0)
    sun.rotation_euler = (math.radians(50.0), 0.0, math.radians(40.0))
    scene.collection.objects.link(sun)

    # Floor just under the bunny, to ground it with a shadow.
    floor_mesh = bpy.data.meshes.new("floor")
    bm = bmesh.new()
    bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=size * 20)
    bm.to_mesh(floor_mesh)
    bm.free()
    floor = bpy.data.objects.new("floor", floor_mesh)
    floor.location = (center.x, center.y, lo.z)
    floor_mat = bpy.data.materials.new("floor")
    floor_mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.45, 0.45, 0.45, 1.0)
    floor_mat.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.9
    floor.data.materials.append(floor_mat)
    scene.collection.objects.link(floor)

    # Camera: front three-quarter view from a little above, aimed at the centre.
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.data.lens = 50.0
    direction = Vector((-0.55, -1.0, 0.45)).normalized()
    cam.location = center + direction * size * 2.8
    cam.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam


def render(path):
    scene = bpy.context.scene
    scene.render.filepath = path
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - start
    print(f"rendered {path} in {seconds:.1f} s ({os.path.getsize(path)} bytes)", flush=True)
    return seconds


def render_level_set(vdb, png, samples):
    vol = import_volume(vdb, "surface")
    vol.hide_render = True  # the volume itself is not shaded; its mesh is

    mesh_obj = bpy.data.objects.new("bunny_surface", bpy.data.meshes.new("bunny_surface"))
    bpy.context.scene.collection.objects.link(mesh_obj)
    mod = mesh_obj.modifiers.new("volume_to_mesh", type="VOLUME_TO_MESH")
    mod.object = vol
    mod.grid_name = "surface"
    mod.resolution_mode = "GRID"  # one cell per voxel
    # The level set is signed distance, negative inside: its surface is the 0 iso
    # value (larger thresholds dilate it by that distance in world units).
    mod.threshold = 0.0
    mod.use_smooth_shade = True

    mat = bpy.data.materials.new("clay")
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.75, 0.55, 0.38, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.7
    mesh_obj.data.materials.append(mat)

    depsgraph = bpy.context.evaluated_depsgraph_get()
    meshed = mesh_obj.evaluated_get(depsgraph).data
    if len(meshed.polygons) == 0:
        raise RuntimeError(f"{vdb}: Volume to Mesh made no faces from grid 'surface'")
    lo, hi = world_bounds(mesh_obj)
    print(
        f"  Volume to Mesh (threshold 0): {len(meshed.vertices)} vertices, {len(meshed.polygons)} faces, "
        f"world size {tuple(round(v, 4) for v in (hi - lo))}",
        flush=True,
    )

    setup_stage(mesh_obj, samples)
    return render(png)


def render_fog(vdb, png, samples):
    vol = import_volume(vdb, "density")
    mat = bpy.data.materials.new("smoke")
    nodes = mat.node_tree.nodes
    for node in list(nodes):
        nodes.remove(node)
    out = nodes.new("ShaderNodeOutputMaterial")
    pv = nodes.new("ShaderNodeVolumePrincipled")  # reads the 'density' attribute
    pv.inputs["Color"].default_value = (0.95, 0.8, 0.65, 1.0)
    pv.inputs["Density"].default_value = FOG_DENSITY
    mat.node_tree.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    vol.data.materials.append(mat)

    setup_stage(vol, samples)
    # Multiple scattering (Cycles' default is single) makes dense smoke light, not grey.
    bpy.context.scene.cycles.volume_bounces = 4
    return render(png)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--volga", required=True, help="path to the volga binary")
    parser.add_argument("--out", required=True, help="directory for the PNGs")
    parser.add_argument("--samples", type=int, default=SAMPLES, help="Cycles samples per pixel")
    parser.add_argument("--keep-vdb", action="store_true", help="write the .vdb files to --out too")
    args = parser.parse_args()

    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    print(f"Blender {bpy.app.version_string}", flush=True)
    with tempfile.TemporaryDirectory(prefix="volga-vdb-") as tmp:
        vdbs = make_vdbs(os.path.abspath(args.volga), out if args.keep_vdb else tmp)
        times = {
            "level set": render_level_set(vdbs["level_set"], os.path.join(out, "blender_level_set.png"), args.samples),
            "fog volume": render_fog(vdbs["fog"], os.path.join(out, "blender_fog.png"), args.samples),
        }
    for kind, seconds in times.items():
        print(f"{kind}: {seconds:.1f} s render", flush=True)


if __name__ == "__main__":
    main()
