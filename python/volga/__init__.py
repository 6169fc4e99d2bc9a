"""volga — a volume graphics modeling kernel, from Python.

Voxelize meshes with proven inside/outside (open, self-intersecting, overlapping and flat
meshes included), compute exact signed distances with certified signs, validate voxel
models with discrete topology, build scenes, sculpt on a dynamic-resolution octree, build
adaptively sampled distance fields and render any of them. numpy arrays in and out.

Conventions
-----------
* **Signed distances are negative inside** (like libigl and OpenVDB). trimesh's
  ``proximity.signed_distance`` and pysdf use the opposite sign: negate to compare.
* *Inside* means generalized winding number ≥ ½, **proven per point or voxel** on every
  mesh, closed or not.
* Grids are indexed ``[i, j, k]`` along x, y, z like trimesh's ``VoxelGrid.matrix``;
  ``grid.transform`` maps index space to world space at voxel centres.
* Every heavy call releases the GIL; ``threads=None`` uses every core (or
  ``RAYON_NUM_THREADS``), ``threads=n`` a pool of ``n``; results are identical for any
  thread count.
* Bad input raises ``ValueError`` naming the argument or field; an allocation that would
  not fit raises ``MemoryError`` naming the size needed before anything is allocated;
  file problems raise ``OSError``.

Example
-------
>>> import volga
>>> mesh = volga.load_mesh("bunny.obj")                      # doctest: +SKIP
>>> grid = volga.voxelize(mesh, resolution=128, mode="solid")  # doctest: +SKIP
>>> grid.matrix.shape, grid.stats["sign"]["exact_voxels"]     # doctest: +SKIP
>>> d = volga.signed_distance(mesh, points)                   # doctest: +SKIP
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _volga
from ._volga import Mesh, VoxelGrid, VoxelJob, __version__

__all__ = [
    "Mesh",
    "VoxelGrid",
    "VoxelJob",
    "Sculpt",
    "Adf",
    "load_mesh",
    "load_volume",
    "signed_distance",
    "winding_number",
    "inside",
    "voxelize",
    "validate",
    "build",
    "SceneJob",
    "extract_mesh",
    "render",
    "default_threads",
    "__version__",
]

MeshLike = Union[Mesh, Tuple[Any, Any], "os.PathLike[str]", str, Any]
PathLike = Union[str, "os.PathLike[str]"]


def _as_mesh(obj: MeshLike, name: str = "mesh") -> Mesh:
    """A ``volga.Mesh`` from a Mesh, a path, a ``(vertices, faces)`` pair or any object
    with ``.vertices`` and ``.faces`` (a ``trimesh.Trimesh``)."""
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load_mesh(obj)
    if isinstance(obj, (tuple, list)) and len(obj) == 2:
        return Mesh(obj[0], obj[1])
    if hasattr(obj, "vertices") and hasattr(obj, "faces"):
        return Mesh(np.asarray(obj.vertices), np.asarray(obj.faces))
    raise ValueError(
        f"{name}: expected a volga.Mesh, a path, a (vertices, faces) pair or an object with "
        f".vertices and .faces, got {type(obj).__name__}"
    )


def _nonfinite(value: Any, path: str) -> Optional[str]:
    """The path of the first NaN or infinite number in a nested value, if any."""
    if isinstance(value, (float, np.floating)):
        return None if np.isfinite(value) else f"{path}: {float(value)} is not a finite number"
    if isinstance(value, np.ndarray) and value.dtype.kind in "fc":
        bad = np.argwhere(~np.isfinite(value))
        return f"{path}{list(bad[0]) if len(bad) else ''}: not finite" if len(bad) else None
    if isinstance(value, dict):
        items = ((f"{path}.{k}", v) for k, v in value.items())
    elif isinstance(value, (list, tuple)):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(value))
    else:
        return None
    for p, v in items:
        found = _nonfinite(v, p)
        if found:
            return found
    return None


def _json(value: Any, what: str = "value") -> str:
    """JSON text of a dict that may hold numpy arrays and scalars; NaN and infinities are
    refused naming their field (JSON cannot hold them)."""
    found = _nonfinite(value, what)
    if found:
        raise ValueError(found)

    def convert(o: Any) -> Any:
        if isinstance(o, np.ndarray):
            return o.tolist()
        if isinstance(o, np.generic):
            return o.item()
        if isinstance(o, os.PathLike):
            return os.fspath(o)
        raise TypeError(f"{type(o).__name__} is not JSON serializable")

    try:
        return json.dumps(value, default=convert, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"cannot express as a scene value: {e}") from None


def default_threads() -> int:
    """Threads a call with ``threads=None`` uses (every core, or ``RAYON_NUM_THREADS``)."""
    return _volga.default_threads()


def load_mesh(path: PathLike, memory_limit: Optional[int] = None) -> Mesh:
    """Read an OBJ, glTF or GLB mesh as a :class:`Mesh`.

    OBJ vertices are welded by position index, not split at texture seams (unlike
    ``trimesh.load``), so closed meshes stay closed; vertices no face uses are dropped. The file's size is checked first:
    parsing it must fit in ``memory_limit`` bytes (default: the machine's available
    memory), else ``MemoryError``. A missing or unreadable file raises ``OSError``; a
    malformed one ``ValueError`` naming the file and line.
    """
    return _volga.load_mesh(os.fspath(path), memory_limit)


def load_volume(path: PathLike) -> VoxelGrid:
    """Read a voxel model (``.binvox``, or a ``.nrrd`` volga or another tool wrote) as a
    :class:`VoxelGrid` (kind ``binary``, ``density`` or ``distance`` from its values)."""
    return _volga.load_volume(os.fspath(path))


def signed_distance(mesh: MeshLike, points: Any, threads: Optional[int] = None) -> np.ndarray:
    """Signed distance from each point to the mesh, **negative inside**.

    ``points`` is (K, 3) of any float/int dtype and layout. The magnitude is the exact
    Euclidean distance to the nearest triangle; the sign is inside iff the generalized
    winding number is ≥ ½, **proven** for every point (certified bounds on the far-field
    expansion, refined until they decide; a mesh's holes are closed by small caps so a
    point near a hole costs a few triangles, not the whole mesh). So open scans,
    self-intersecting, overlapping, inconsistently oriented and flat meshes get the answer
    the winding number defines, not a ray-parity guess.

    Points are processed in parallel chunks: memory is O(K), never K × triangles.
    Returns (K,) float64. An empty mesh gives +inf.

    Note: trimesh and pysdf return the opposite sign (positive inside).
    """
    return _volga.signed_distance(_as_mesh(mesh), points, threads)


def winding_number(
    mesh: MeshLike, points: Any, tolerance: Optional[float] = None, threads: Optional[int] = None
) -> np.ndarray:
    """Generalized winding number (Jacobson et al. 2013) at each point: 1 inside a closed
    outward-oriented mesh, 0 outside, ½ on it, fractional near holes. Returns (K,) float64.

    ``tolerance=None`` (default): the fast winding number of Barill et al. 2018 (a
    two-term far-field expansion, the method libigl's ``fast_winding_number`` uses);
    typically within 1e-2 of the exact sum but **not certified**. A number: the value is
    within ``tolerance`` of the exact sum of the triangles' solid angles, **certified**
    (rigorous bounds refined until they are below it; 0 sums every triangle). The
    certified bounds are loose, so small tolerances cost up to a full sum over the mesh per
    point near the surface. To decide inside/outside use :func:`inside`: it is proven and
    fast."""
    return _volga.winding_number(_as_mesh(mesh), points, tolerance, threads)


def inside(mesh: MeshLike, points: Any, threads: Optional[int] = None) -> np.ndarray:
    """Whether each point's winding number is ≥ ½, proven. Returns (K,) bool."""
    return _volga.inside(_as_mesh(mesh), points, threads)


def voxelize(
    mesh: MeshLike,
    resolution: Optional[int] = None,
    pitch: Optional[float] = None,
    bounds: Any = None,
    mode: str = "surface",
    separability: Optional[int] = None,
    band: Optional[float] = None,
    thickness: Optional[float] = None,
    solid: Optional[bool] = None,
    signed: Optional[bool] = None,
    memory_limit: Optional[int] = None,
    threads: Optional[int] = None,
    region: Any = None,
) -> VoxelGrid:
    """Voxelize a mesh into a sparse :class:`VoxelGrid`.

    Grid: give ``resolution`` (voxels along the longest side) or ``pitch`` (voxel size in
    world units). Without ``bounds`` the mesh's box is padded by the band plus one voxel
    on every side, exactly as ``volga voxelize`` lays it out (same resolution, same grid,
    same bits). With ``bounds=((xmin, ymin, zmin), (xmax, ymax, zmax))`` the grid starts at
    ``min`` (voxel centres at ``min + pitch/2 + ijk·pitch``) and has
    ``ceil((max − min)/pitch)`` voxels per axis, so its last voxel reaches past ``max`` when
    the size is not a multiple of the pitch.

    Modes:

    * ``"surface"`` — binary surface, ``separability`` 6, 18 or 26 (default 26; the white
      set cannot leak through it with that adjacency; Huang, Yagel, Filippov & Kurzion
      1998).
    * ``"solid"`` — the binary surface plus every voxel whose winding number is ≥ ½.
    * ``"anti_aliased"`` — oriented box filter densities (Sramek & Kaufman): a surface
      of ``thickness`` voxels (default 1), or with ``solid=True`` the solid (0.5 on its
      surface).
    * ``"distance"`` — narrow-band distance (world units) of half-width ``band`` voxels
      (default 3), signed (negative inside) unless ``signed=False``; background = the band.

    An option the mode does not use (``band`` with ``"surface"``, say) is refused with
    ``ValueError``, as ``volga voxelize`` refuses its flags.

    The memory the run needs is estimated from the triangles and the grid before anything
    is allocated and refused over ``memory_limit`` (default: the machine's available
    memory) with ``MemoryError``. ``grid.stats`` reports how every sign was proven.
    """
    return _volga.voxelize(
        _as_mesh(mesh),
        resolution,
        pitch,
        bounds,
        mode,
        separability,
        band,
        thickness,
        solid,
        signed,
        memory_limit,
        threads,
        region,
    )


def validate(
    grid: Any,
    connectivity: int = 26,
    mesh: Optional[MeshLike] = None,
    require: Sequence[str] = ("separating",),
    transform: Any = None,
    pad: bool = False,
    listed: int = 32,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """Validate a voxel model with discrete topology; returns the report as a dict, the
    same JSON as ``volga validate --json`` (schema in docs/VALIDATE.md).

    ``grid`` is a :class:`VoxelGrid` (binary or density; black = density ≥ 0.5) or a 3-D
    array indexed ``[i, j, k]`` (bool, or numbers thresholded at 0.5). ``connectivity`` N
    is the adjacency of white paths (6, 18 or 26; black uses the opposite type). With a
    reference ``mesh`` (in the model's world space: ``transform`` maps an array's indices
    to world at voxel centres, default the identity; a grid carries its own), the report
    adds N-tunnels through the mesh with their locations, cover and minimal cover.

    ``require`` lists the properties ``passed`` follows: ``separating``, ``minimal``,
    ``cover``. ``pad`` adds one white layer around the grid.
    """
    if isinstance(require, str):
        require = [require]
    m = _as_mesh(mesh) if mesh is not None else None
    return _volga.validate(grid, connectivity, m, list(require), transform, pad, listed, threads)


def build(
    scene: Union[PathLike, Dict[str, Any]],
    out: PathLike,
    memory_limit: Optional[int] = None,
    base_dir: Optional[PathLike] = None,
    threads: Optional[int] = None,
    allow_outside_paths: bool = False,
) -> Dict[str, Any]:
    """Build a scene like ``volga build``: images, volumes, meshes and ``report.json`` in
    ``out``, all or nothing. Returns the build report (dict).

    ``scene`` is a scene file (``.ron`` or ``.json``) or a dict with the same field names
    as a JSON scene file (docs/SCENE_FORMAT.md); a dict's relative paths are read from
    ``base_dir`` (default: the current directory). Files the scene names must lie in that
    folder (no absolute paths, no ``..`` above it) unless ``allow_outside_paths``.
    """
    if isinstance(scene, dict):
        base = os.fspath(base_dir) if base_dir is not None else os.getcwd()
        name = os.path.join(base, "<scene dict>")
        return _volga.build(
            name, os.fspath(out), _json(scene, "scene"), memory_limit, threads, allow_outside_paths
        )
    return _volga.build(os.fspath(scene), os.fspath(out), None, memory_limit, threads, allow_outside_paths)


class SceneJob:
    """A scene validated and its files loaded once, baked region by region.

    ``scene`` is a scene file or a dict, as for :func:`build`. ``shape`` and ``transform``
    describe the scene's grid; ``bake(region=None, memory_limit=None, threads=None)``
    returns the baked density over ``region = ((i0, j0, k0), (i1, j1, k1))`` (default: the
    whole grid) as a :class:`VoxelGrid` of its own, **bit for bit** the whole bake's voxels
    (meshes with proven signs, ADFs, sculpts, CVG trees, textures), computing only the 8³
    bricks that meet the region; its memory is checked for the region first
    (``MemoryError``). :func:`volga.dask.bake_array` makes a lazy array of chunks of it.
    """

    def __init__(
        self,
        scene: Union[PathLike, Dict[str, Any]],
        base_dir: Optional[PathLike] = None,
        memory_limit: Optional[int] = None,
        allow_outside_paths: bool = False,
    ) -> None:
        if isinstance(scene, dict):
            base = os.fspath(base_dir) if base_dir is not None else os.getcwd()
            self._inner = _volga.SceneJob(
                os.path.join(base, "<scene dict>"), _json(scene, "scene"), memory_limit, allow_outside_paths
            )
        else:
            self._inner = _volga.SceneJob(os.fspath(scene), None, memory_limit, allow_outside_paths)

    @property
    def shape(self) -> Tuple[int, int, int]:
        return self._inner.shape

    @property
    def transform(self) -> np.ndarray:
        return self._inner.transform

    def bake(self, region: Any = None, memory_limit: Optional[int] = None,
             threads: Optional[int] = None) -> VoxelGrid:
        return self._inner.bake(region, memory_limit, threads)


def extract_mesh(
    grid: VoxelGrid,
    iso: Optional[float] = None,
    threads: Optional[int] = None,
    method: str = "cubes",
    adaptivity: float = 0.0,
) -> Tuple[np.ndarray, np.ndarray]:
    """The iso-surface of a grid's trilinear field as ``(vertices (N, 3) float64,
    faces (M, 3) int64)`` on the lattice of voxel centres grown by one voxel (where the
    grid reads its background): closed and manifold even where the surface touches the
    grid's last voxels, oriented outward, vertices refined onto the surface. ``iso`` defaults to 0.5 for
    binary and density grids and 0 for distances. ``method``: ``"cubes"`` (marching cubes
    with the asymptotic decider), ``"dual"`` (dual contouring: sharp edges kept) or
    ``"tetrahedra"``; ``adaptivity`` (voxels, 0 to 10) merges vertices while each stays
    within that distance of the planes of the triangles it replaces (docs/EXTRACT.md)."""
    return _volga.extract_mesh(grid, iso, threads, method, adaptivity)


def _unwrap(obj: Any) -> Any:
    return obj._inner if isinstance(obj, (Sculpt, Adf)) else obj


def render(
    obj: Any,
    width: int = 512,
    height: int = 512,
    mode: str = "iso",
    eye: Any = None,
    target: Any = None,
    up: Any = None,
    fov_deg: float = 30.0,
    iso: Optional[float] = None,
    colour: Any = None,
    threads: Optional[int] = None,
) -> np.ndarray:
    """Render a :class:`VoxelGrid`, :class:`Sculpt` or :class:`Adf` with the embedded
    raycaster; returns an (height, width, 4) uint8 RGBA image, row 0 at the top.

    ``mode``: ``"iso"`` (Phong-shaded iso-surface at ``iso``: 0.5 for densities, 0 for
    distances; a sculpt's own colours unless ``colour`` is given), ``"mip"`` (maximum
    intensity) or ``"xray"``. The camera is a perspective one (``fov_deg``) framing the
    object from the front, above and right, unless ``eye``/``target``/``up`` are given.
    """
    return _volga.render(_unwrap(obj), width, height, mode, eye, target, up, fov_deg, iso, colour, threads)


def _tool(tool: Any) -> Any:
    """A stroke tool as scene JSON: a shape dict (``{"Sphere": {"center": …, "radius": …}}``)
    or a closed mesh (any mesh-like object), as inline triangles."""
    if isinstance(tool, dict):
        return tool
    m = _as_mesh(tool, "tool")
    return {"Triangles": {"vertices": m.vertices.tolist(), "triangles": m.faces.tolist()}}


class Sculpt:
    """A sculpt: a free-form solid on Bærentzen's dynamic-resolution octree (survey
    §17.9), edited with volume-sampled tools, with undo/redo and save/load.

    ``Sculpt(bounds, voxel_size, object=None, colour=None)`` starts from ``object`` — a
    shape dict as in scene files (``{"Box": {"min": …, "max": …}}``), an object dict
    (``{"shape": …, "colour": …}``) or a closed mesh — sampled on a grid covering
    ``bounds`` with voxels of ``voxel_size`` (8·2^L voxels per axis, at most 16384), or
    empty when ``object`` is None.

    Tools are shape dicts or closed meshes, placed by ``rotation_deg`` (XYZ Euler, about
    the world origin) then ``translate``; with ``path`` (a polyline) the tool is swept
    along it (the saw). Each edit returns ``{"changed_voxels", "changed_world"}``: the box
    of voxels it changed and the world box a re-render must redo (``None``: no change).
    """

    def __init__(
        self,
        bounds: Any,
        voxel_size: float,
        object: Any = None,
        colour: Any = None,
        memory_limit: Optional[int] = None,
    ) -> None:
        lo, hi = (np.asarray(b, dtype=np.float64).tolist() for b in bounds)
        start: Dict[str, Any] = {"bounds": {"min": lo, "max": hi}, "voxel_size": voxel_size}
        if object is None:
            start["object"] = None
            if colour is not None:
                start["colour"] = list(colour)
        else:
            if isinstance(object, dict) and "shape" in object:
                obj = dict(object)
            else:
                obj = {"shape": _tool(object)}
            if colour is not None:
                obj["colour"] = list(colour)
            start["object"] = obj
        self._inner = _volga.Sculpt(_json(start, "start"), memory_limit)

    @classmethod
    def _wrap(cls, inner: Any) -> "Sculpt":
        s = cls.__new__(cls)
        s._inner = inner
        return s

    @classmethod
    def open(cls, path: PathLike, memory_limit: Optional[int] = None) -> "Sculpt":
        """Open a sculpt file (``.vsculpt``, as ``volga sculpt --out`` writes)."""
        return cls._wrap(_volga.Sculpt.open(os.fspath(path), memory_limit))

    @classmethod
    def from_bytes(cls, data: bytes) -> "Sculpt":
        """A sculpt from a sculpt file's bytes."""
        return cls._wrap(_volga.Sculpt.from_bytes(data))

    def to_bytes(self) -> bytes:
        """The sculpt file's bytes (versioned, checksummed)."""
        return self._inner.to_bytes()

    def save(self, path: PathLike) -> None:
        """Write the sculpt file, all or nothing."""
        self._inner.save(os.fspath(path))

    def _apply(self, op: Any, tool: Any, rotation_deg: Any, translate: Any, path: Any, threads: Optional[int]) -> Dict[str, Any]:
        stroke: Dict[str, Any] = {"op": op, "tool": _tool(tool)}
        if rotation_deg is not None:
            stroke["rotation_deg"] = rotation_deg
        if translate is not None:
            stroke["translate"] = translate
        if path is not None:
            stroke["path"] = np.asarray(path, dtype=np.float64).tolist()
        return self._inner.apply(_json(stroke, "stroke"), threads)

    def carve(self, tool: Any, *, rotation_deg: Any = None, translate: Any = None, path: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Subtract the tool's volume (density becomes min(d, 1 − tool))."""
        return self._apply("Carve", tool, rotation_deg, translate, path, threads)

    def add(self, tool: Any, *, rotation_deg: Any = None, translate: Any = None, path: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Add the tool's volume (density becomes max(d, tool))."""
        return self._apply("Add", tool, rotation_deg, translate, path, threads)

    def spray(self, tool: Any, strength: float = 1.0, falloff: float = 0.0, *, rotation_deg: Any = None, translate: Any = None, path: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Deposit material additively (``strength`` per stroke, soft edge ``falloff``
        world units wide)."""
        return self._apply({"Spray": {"strength": strength, "falloff": falloff}}, tool, rotation_deg, translate, path, threads)

    def paint(self, tool: Any, colour: Any, strength: float = 1.0, *, rotation_deg: Any = None, translate: Any = None, path: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Paint the material inside the tool with a linear RGB ``colour``."""
        return self._apply({"Paint": {"colour": list(colour), "strength": strength}}, tool, rotation_deg, translate, path, threads)

    def smooth(self, tool: Any, strength: float = 1.0, *, rotation_deg: Any = None, translate: Any = None, path: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Blend densities toward their neighbourhood mean inside the tool."""
        return self._apply({"Smooth": {"strength": strength}}, tool, rotation_deg, translate, path, threads)

    def saw(self, tool: Any, path: Any, *, rotation_deg: Any = None, translate: Any = None, threads: Optional[int] = None) -> Dict[str, Any]:
        """Carve with the tool swept along the polyline ``path`` (sampled every half voxel)."""
        return self._apply("Carve", tool, rotation_deg, translate, path, threads)

    def undo(self) -> bool:
        """Undo the last edit; False when there is none."""
        return self._inner.undo()

    def redo(self) -> bool:
        """Redo the last undone edit; False when there is none."""
        return self._inner.redo()

    @property
    def undo_len(self) -> int:
        return self._inner.undo_len

    @property
    def redo_len(self) -> int:
        return self._inner.redo_len

    @property
    def stats(self) -> Dict[str, Any]:
        """Grid (origin, voxel_size, levels, dims) and tree statistics (nodes, bytes)."""
        return self._inner.stats

    def value(self, points: Any) -> np.ndarray:
        """Density (trilinear) at world points (K, 3)."""
        return self._inner.value(points)

    def to_mesh(self, cell_voxels: float = 1.0, threads: Optional[int] = None) -> Tuple[np.ndarray, np.ndarray]:
        """The surface (density ½) as ``(vertices, faces)``, closed and manifold."""
        return self._inner.to_mesh(cell_voxels, threads)

    def to_grid(self) -> VoxelGrid:
        """The densities as a :class:`VoxelGrid` on the sculpt's grid."""
        return self._inner.to_grid()

    def render(self, width: int = 512, height: int = 512, **kwargs: Any) -> np.ndarray:
        """:func:`volga.render` of this sculpt."""
        return render(self, width, height, **kwargs)

    def __repr__(self) -> str:
        return repr(self._inner)


class Adf:
    """An adaptively sampled distance field (Frisken, Perry, Rockwood & Jones 2000):
    an octree whose cells store corner distances, split until trilinear reconstruction is
    within the tolerance. Distances are negative inside.

    Build with :meth:`Adf.from_mesh` (exact distances, certified winding-number signs, so
    open and self-intersecting meshes work) or :meth:`Adf.from_shape`. ``tolerance`` and
    ``band`` are fractions of the source's bounding-box diagonal. ADFs pickle as the
    recipe that built them (the build is deterministic).
    """

    def __init__(self, inner: Any) -> None:
        self._inner = inner

    @classmethod
    def from_mesh(cls, mesh: MeshLike, tolerance: float = 1e-3, max_depth: int = 12, band: float = 0.0, threads: Optional[int] = None) -> "Adf":
        """The ADF of a mesh."""
        return cls(_volga.Adf.from_mesh(_as_mesh(mesh), tolerance, max_depth, band, threads))

    @classmethod
    def from_shape(cls, shape: Dict[str, Any], tolerance: float = 1e-3, max_depth: int = 12, band: float = 0.0, threads: Optional[int] = None) -> "Adf":
        """The ADF of an analytic shape given as in scene files, e.g.
        ``{"Sphere": {"center": [0, 0, 0], "radius": 1}}``."""
        return cls(_volga.Adf.from_shape(_json(shape, "shape"), tolerance, max_depth, band, threads))

    def distance(self, points: Any, threads: Optional[int] = None) -> np.ndarray:
        """Signed distance at world points (K, 3) → (K,) float64."""
        return self._inner.distance(points, threads)

    def gradient(self, points: Any, threads: Optional[int] = None) -> np.ndarray:
        """Gradient of the distance at world points → (K, 3) float64."""
        return self._inner.gradient(points, threads)

    def closest_point(self, points: Any, threads: Optional[int] = None) -> np.ndarray:
        """Closest surface points → (K, 3) float64."""
        return self._inner.closest_point(points, threads)

    def inside(self, points: Any, threads: Optional[int] = None) -> np.ndarray:
        """Whether each point is inside (distance < 0) → (K,) bool."""
        return self._inner.inside(points, threads)

    def union(self, other: "Adf", threads: Optional[int] = None) -> "Adf":
        return Adf(self._inner.combine(other._inner, "union", threads))

    def intersection(self, other: "Adf", threads: Optional[int] = None) -> "Adf":
        return Adf(self._inner.combine(other._inner, "intersection", threads))

    def difference(self, other: "Adf", threads: Optional[int] = None) -> "Adf":
        """This ADF minus ``other``."""
        return Adf(self._inner.combine(other._inner, "difference", threads))

    def to_mesh(
        self,
        cell: Optional[float] = None,
        threads: Optional[int] = None,
        on_leaves: bool = False,
        method: str = "cubes",
        adaptivity: float = 0.0,
    ) -> Tuple[np.ndarray, np.ndarray]:
        """The zero iso-surface as ``(vertices, faces)``, closed and manifold: on a lattice
        of ``cell`` world units (default: 1/256 of the source's longest side), or with
        ``on_leaves=True`` on the ADF's own leaves (its dual grid: large triangles where the
        leaves are large; ``cell`` must then be left out). ``method``: ``"cubes"``,
        ``"dual"`` (lattice only) or ``"tetrahedra"``; ``adaptivity`` (0 to 10, in cells,
        or in the finest leaf's size on the leaves) merges vertices within that distance
        of the planes of the triangles they replace (docs/EXTRACT.md)."""
        return self._inner.to_mesh(cell, threads, on_leaves, method, adaptivity)

    @property
    def stats(self) -> Dict[str, Any]:
        """Cells, leaves, depth reached, evaluations, bytes, world tolerance."""
        return self._inner.stats

    @property
    def cell_count(self) -> int:
        return self._inner.cell_count

    @property
    def root_box(self) -> np.ndarray:
        """(2, 3) root cube of the octree."""
        return self._inner.root_box

    def render(self, width: int = 512, height: int = 512, **kwargs: Any) -> np.ndarray:
        """:func:`volga.render` of this ADF."""
        return render(self, width, height, **kwargs)

    def __repr__(self) -> str:
        return repr(self._inner)
