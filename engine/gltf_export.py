"""Export takes as glTF 2.0 with the skinned batsman, for Blender, three.js,
game engines: ``write_gltf(path, skeleton, takes)`` writes ``.glb`` (binary) or
``.gltf`` (JSON with the buffer embedded as a data URI), atomically.

What the file holds:

* one root node named for the character (``Batsman``) with no transform,
  holding the joints as nodes in the skeleton's order (``parents[i] < i``),
  rest translation = ``skeleton.offsets``, no rest rotation (rest frames are
  world-aligned, as everywhere in Hitpoint);
* the ``Batsman`` skinned mesh (node ``Batsman_body``, at the scene root as glTF
  wants skinned meshes) and its skin from ``assets/batsman.glb``, matched to the
  skeleton by joint name; only the visible body (no shadow caster, no levels of
  detail, no renderer attributes);
* with a ball track, a ``Ball`` node with the ball mesh, animated: it comes in
  on a straight line, meets the bat at the hit frame, then flies;
* one animation per take (the source and the adapted shot): a rotation
  channel per joint ((x,y,z,w) quaternions, glTF's order; Hitpoint's own
  arrays are (w,x,y,z)), a translation channel on the root (and on any joint
  whose clip animates its translation) and on the ball, LINEAR samplers, key
  times ``frame / fps`` seconds. The animation's ``extras`` state the take,
  ``fps``, ``frames``, ``hit_frame``, ``hit_time_s``, the hit point and the units.

Units: metres (glTF's unit; Hitpoint works in cm and converts here: joint
offsets, translations, vertices, inverse bind matrices and the ball all x 0.01),
Y up, +Z toward the bowler. No scale node: the batsman imports 1.8 m tall with
unit scale everywhere.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import quat
from .atomic import atomic_output
from .skeleton import Clip, Skeleton, bind_positions, local_translations

EXTENSIONS = (".glb", ".gltf")
METRES_PER_CM = 0.01
CHARACTER = "Batsman"            # the root node (Blender: the armature object)
MESH_NAME = "Batsman"            # the skinned mesh in assets/batsman.glb and in the export
MESH_NODE_NAME = "Batsman_body"
BALL_NAME = "Ball"
UNITS = "metres, Y up, +Z toward the bowler (Hitpoint works in cm: x 0.01 here)"


@dataclass
class Take:
    """One animation of the file: ``clip`` (cm) named ``name``; ``extras`` go into the
    animation's extras; ``ball_times (K,)`` s and ``ball_positions (K, 3)`` cm animate
    the ball node (None: no ball in this take)."""
    name: str
    clip: Clip
    extras: dict = field(default_factory=dict)
    ball_times: np.ndarray | None = None
    ball_positions: np.ndarray | None = None

# glTF constants (the spec's numbers; pygltflib names them the same)
_FLOAT, _ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 5126, 34962, 34963
# Standard attributes carried over; app-specific ones (``_GLOSS``) stay behind.
_ATTRIBUTES = ("POSITION", "NORMAL", "COLOR_0", "JOINTS_0", "WEIGHTS_0")
# Bind positions of the mesh's skin and of the skeleton must agree this well (cm).
_BIND_TOLERANCE_CM = 1e-3


def default_mesh_path() -> Path:
    from .rig import assets_dir
    return assets_dir() / "batsman.glb"


# numpy dtypes an accessor stores, and their glTF componentType
_COMPONENTS = {np.dtype(np.float32): _FLOAT, np.dtype(np.uint8): 5121, np.dtype(np.uint16): 5123,
               np.dtype(np.uint32): 5125}


class GltfBuffer:
    """One binary buffer being filled: bufferViews and accessors appended to ``gltf`` as we go
    (this exporter's, and tools/make_batsman's for the bundled mesh)."""

    def __init__(self, gltf):
        self.gltf = gltf
        self.blob = bytearray()

    def view(self, data: bytes, target=None, stride=None) -> int:
        """A new bufferView over ``data`` (4-byte aligned); returns its index."""
        import pygltflib as g
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data),
                                                  target=target, byteStride=stride))
        self.blob.extend(data)
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array: np.ndarray, kind: str, minmax: bool = False, target=None,
                 normalized: bool = False) -> int:
        """An accessor over ``array (N,)`` or ``(N, k)``: floats as float32, uint8, uint16 or
        uint32 as they are; returns its index."""
        import pygltflib as g
        a = np.ascontiguousarray(array)
        a = a.astype(np.float32) if a.dtype.kind == "f" else a
        if a.dtype not in _COMPONENTS:
            raise ValueError(f"glTF accessor: no component type for {a.dtype}")
        acc = g.Accessor(bufferView=self.view(a.tobytes(), target), componentType=_COMPONENTS[a.dtype],
                         count=len(a), type=kind, normalized=normalized or None)   # None: the default, left out
        if minmax:  # required on animation inputs and positions
            flat = a.reshape(len(a), -1)
            acc.min, acc.max = [float(x) for x in flat.min(0)], [float(x) for x in flat.max(0)]
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1


# ----------------------------------------------------------------- checks
def check_clip(skeleton: Skeleton, clip: Clip) -> None:
    """ValueError (one line) for a clip that cannot be exported."""
    J, F = skeleton.num_joints, clip.num_frames
    if clip.local_rotations.shape != (F, J, 4) or clip.root_positions.shape != (F, 3):
        raise ValueError(f"glTF export: clip shapes {clip.local_rotations.shape}/{clip.root_positions.shape} "
                         f"do not match {J} joints")
    if F < 1:
        raise ValueError("glTF export: the clip has no frames")
    if not (np.isfinite(clip.fps) and clip.fps > 0):
        raise ValueError(f"glTF export: fps must be a positive number, got {clip.fps}")
    arrays = [clip.local_rotations, clip.root_positions] + (
        [] if clip.local_positions is None else [clip.local_positions])
    if not all(np.isfinite(a).all() for a in arrays):
        raise ValueError("glTF export: the clip has NaN or infinite values")


# ----------------------------------------------------------------- mesh copy
def _copy_accessor(src, src_blob: bytes, index: int, out: GltfBuffer, memo: dict) -> int:
    """Copy accessor ``index`` of ``src`` (and its bufferView bytes, once) into ``out``."""
    if index in memo:
        return memo[index]
    acc = copy.deepcopy(src.accessors[index])
    view = src.bufferViews[acc.bufferView]
    start = view.byteOffset or 0
    key = ("view", acc.bufferView)
    if key not in memo:
        memo[key] = out.view(src_blob[start:start + view.byteLength], view.target, view.byteStride)
    acc.bufferView = memo[key]
    out.gltf.accessors.append(acc)
    memo[index] = len(out.gltf.accessors) - 1
    return memo[index]


def _floats(src, src_blob: bytes, index: int, width: int) -> np.ndarray:
    """A tightly packed float accessor of ``src`` as ``(count, width)`` float32."""
    acc = src.accessors[index]
    view = src.bufferViews[acc.bufferView]
    if acc.componentType != _FLOAT or (view.byteStride or 4 * width) != 4 * width:
        raise ValueError("mesh file: expected tightly packed float positions and matrices")
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    return np.frombuffer(src_blob, np.float32, width * acc.count, start).reshape(acc.count, width)


def _find_mesh(src, name: str, skinned: bool):
    """The node index showing mesh ``name`` in ``src`` (skinned or not), or None."""
    for i, node in enumerate(src.nodes):
        if node.mesh is not None and src.meshes[node.mesh].name == name and (node.skin is not None) == skinned:
            return i
    return None


def _mesh_skin_names(src) -> tuple[int, object, list[str]]:
    """(mesh index, skin, skin joint names) of the ``Batsman`` mesh in ``src``."""
    i = _find_mesh(src, MESH_NAME, skinned=True)
    if i is None:
        raise ValueError(f"no skinned mesh {MESH_NAME!r} in the mesh file")
    skin = src.skins[src.nodes[i].skin]
    return src.nodes[i].mesh, skin, [src.nodes[j].name for j in skin.joints]


def _inverse_binds(src, src_blob: bytes, skin, count: int) -> np.ndarray:
    """``(count, 4, 4)`` inverse bind matrices of ``skin`` (cm), row-major."""
    return _floats(src, src_blob, skin.inverseBindMatrices, 16).reshape(count, 4, 4).transpose(0, 2, 1)


def _check_bind(ibm: np.ndarray, names: list[str], skeleton: Skeleton, where) -> None:
    """The mesh was bound to this skeleton's rest pose (else it would shear)."""
    want = np.tile(np.eye(4), (len(names), 1, 1))    # world-aligned rest frames: a pure translation
    want[:, :3, 3] = -bind_positions(skeleton)[[skeleton.names.index(n) for n in names]]
    err = np.abs(ibm - want).max(axis=(1, 2))
    if err.max() > _BIND_TOLERANCE_CM:
        j = int(err.argmax())
        raise ValueError(f"{where}: the mesh is bound to another rest pose (joint {names[j]!r} "
                         f"{err[j]:.3g} cm off); export without the mesh")


class _MeshSource:
    """``assets/batsman.glb`` (or another mesh file) opened once for copying."""

    def __init__(self, mesh_path: Path):
        import pygltflib as g
        self.path = mesh_path
        self.src = g.GLTF2().load(str(mesh_path))
        self.blob = self.src.binary_blob()
        if self.blob is None:
            raise ValueError(f"{mesh_path}: no binary buffer (expected a .glb)")
        self.memo: dict = {}
        self.materials: dict = {}

    def mesh(self, gltf, out: GltfBuffer, index: int, name: str) -> int:
        """Copy mesh ``index`` (positions to metres) into ``gltf``; its new index."""
        import pygltflib as g
        prims = [self._primitive(gltf, p, out) for p in self.src.meshes[index].primitives]
        gltf.meshes.append(g.Mesh(name=name, primitives=prims))
        return len(gltf.meshes) - 1

    def _primitive(self, gltf, p, out: GltfBuffer):
        """One primitive with its standard attributes, indices and material."""
        import pygltflib as g
        attrs = {}
        for a in _ATTRIBUTES:
            index = getattr(p.attributes, a, None)
            if index is None:
                continue
            if a == "POSITION":      # cm -> m; min/max are required on positions
                attrs[a] = out.accessor(_floats(self.src, self.blob, index, 3) * METRES_PER_CM, "VEC3",
                                        minmax=True, target=_ARRAY_BUFFER)
            else:
                attrs[a] = _copy_accessor(self.src, self.blob, index, out, self.memo)
        if p.material is not None and p.material not in self.materials:
            gltf.materials.append(copy.deepcopy(self.src.materials[p.material]))
            self.materials[p.material] = len(gltf.materials) - 1
        indices = None if p.indices is None else _copy_accessor(self.src, self.blob, p.indices, out, self.memo)
        return g.Primitive(attributes=g.Attributes(**attrs), mode=p.mode, indices=indices,
                           material=self.materials.get(p.material))


def _add_body(gltf, out: GltfBuffer, skeleton: Skeleton, source: _MeshSource) -> int:
    """The skinned batsman (mesh, material, skin) into ``gltf``; returns its node index."""
    import pygltflib as g
    mesh_index, skin, names = _mesh_skin_names(source.src)
    missing = [n for n in names if n not in skeleton.names]
    if missing:
        raise ValueError(f"{source.path}: skin joint {missing[0]!r} is not in the skeleton")
    ibm = None
    if skin.inverseBindMatrices is not None:
        binds = _inverse_binds(source.src, source.blob, skin, len(names))
        _check_bind(binds, names, skeleton, source.path)
        binds = binds.copy()
        binds[:, :3, 3] *= METRES_PER_CM
        ibm = out.accessor(binds.transpose(0, 2, 1).reshape(-1, 16), "MAT4")   # glTF: column-major
    mesh = source.mesh(gltf, out, mesh_index, MESH_NAME)
    joints = [skeleton.names.index(n) for n in names]      # joint nodes are 0..J-1 in skeleton order
    gltf.skins.append(g.Skin(name="rig", joints=joints, inverseBindMatrices=ibm))
    gltf.nodes.append(g.Node(name=MESH_NODE_NAME, mesh=mesh, skin=len(gltf.skins) - 1))
    return len(gltf.nodes) - 1


def _add_ball(gltf, out: GltfBuffer, source: _MeshSource | None) -> int:
    """The ball node (with the ball mesh of the mesh file, if any); its index."""
    import pygltflib as g
    node = g.Node(name=BALL_NAME)
    if source is not None:
        i = _find_mesh(source.src, BALL_NAME, skinned=False)
        if i is not None:
            node.mesh = source.mesh(gltf, out, source.src.nodes[i].mesh, BALL_NAME)
    gltf.nodes.append(node)
    return len(gltf.nodes) - 1


# ----------------------------------------------------------------- animation
def gltf_rotations(local_rotations: np.ndarray) -> np.ndarray:
    """``(F, J, 4)`` (w,x,y,z) -> ``(F, J, 4)`` float32 (x,y,z,w) unit quaternions,
    signs continuous over frames so LINEAR (slerp) keys take the short way."""
    q = quat.make_continuous(quat.normalize(local_rotations), axis=0)
    q = q[..., [1, 2, 3, 0]].astype(np.float32)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)   # unit again after the float32 rounding


def _animated_translations(skeleton: Skeleton, clip: Clip) -> tuple[list[int], np.ndarray]:
    """Joints that get a translation channel (the root, and any joint whose clip
    moves it off its offset) and the ``(F, J, 3)`` local translations (cm)."""
    t = local_translations(skeleton, clip)
    moving = [j for j in range(skeleton.num_joints)
              if j == 0 or not np.allclose(t[:, j], skeleton.offsets[j], atol=1e-9)]
    return moving, t


def _add_animation(gltf, out: GltfBuffer, skeleton: Skeleton, take: Take, ball_node: int | None) -> None:
    import pygltflib as g
    clip = take.clip
    times = out.accessor(np.arange(clip.num_frames) / clip.fps, "SCALAR", minmax=True)
    samplers, channels = [], []

    def channel(node: int, path: str, values: np.ndarray, kind: str, keys: int = times) -> None:
        samplers.append(g.AnimationSampler(input=keys, output=out.accessor(values, kind), interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                           target=g.AnimationChannelTarget(node=node, path=path)))

    rot = gltf_rotations(clip.local_rotations)
    for j in range(skeleton.num_joints):
        channel(j, "rotation", rot[:, j], "VEC4")
    moving, t = _animated_translations(skeleton, clip)
    for j in moving:
        channel(j, "translation", t[:, j] * METRES_PER_CM, "VEC3")
    if ball_node is not None and take.ball_times is not None:
        channel(ball_node, "translation", np.asarray(take.ball_positions) * METRES_PER_CM, "VEC3",
                out.accessor(take.ball_times, "SCALAR", minmax=True))
    extras = {"fps": round(float(clip.fps), 3), "frames": int(clip.num_frames), "units": UNITS, **take.extras}
    gltf.animations.append(g.Animation(name=take.name, samplers=samplers, channels=channels, extras=extras))


# ----------------------------------------------------------------- document
def _joint_nodes(skeleton: Skeleton) -> list:
    import pygltflib as g
    return [g.Node(name=n, translation=[float(x) * METRES_PER_CM for x in skeleton.offsets[i]],
                   children=skeleton.children(i) or None)
            for i, n in enumerate(skeleton.names)]


def _check_takes(skeleton: Skeleton, takes: list[Take]) -> None:
    if not takes:
        raise ValueError("glTF export: no take to write")
    for take in takes:
        check_clip(skeleton, take.clip)
        if take.ball_times is not None:
            t, p = np.asarray(take.ball_times, float), np.asarray(take.ball_positions, float)
            if t.ndim != 1 or p.shape != (len(t), 3) or not (np.isfinite(t).all() and np.isfinite(p).all()) \
                    or np.any(np.diff(t) <= 0):
                raise ValueError(f"glTF export: take {take.name!r}: the ball track needs increasing times "
                                 "and finite (K, 3) positions")


def _summary(takes: list[Take]) -> dict:
    """What the character's node and the scene say (Blender shows them as custom
    properties; it does not import an animation's extras): units, rate, hit, takes."""
    first = takes[0]
    keys = ("hit_frame", "hit_time_s", "hit_point_cm")
    return {"units": UNITS, "fps": round(float(first.clip.fps), 3), "frames": int(first.clip.num_frames),
            **{k: first.extras[k] for k in keys if k in first.extras}, "takes": [t.name for t in takes]}


def build_gltf(skeleton: Skeleton, takes: Clip | list[Take], mesh_path: str | Path | None = None,
               with_mesh: bool = True, name: str = "shot", character: str = CHARACTER):
    """The glTF document (``pygltflib.GLTF2`` with its binary blob set) of ``takes``
    (or one clip, named ``name``).

    Node order: joints ``0..J-1`` (skeleton order), then the body node, the
    ball node (when a take has a ball track) and the character's root node.
    """
    import pygltflib as g
    takes = [Take(name, takes)] if isinstance(takes, Clip) else list(takes)
    _check_takes(skeleton, takes)
    gltf = g.GLTF2(asset=g.Asset(version="2.0", generator="hitpoint engine/gltf_export.py"),
                   scene=0, nodes=_joint_nodes(skeleton))
    out = GltfBuffer(gltf)
    source = _MeshSource(Path(mesh_path) if mesh_path else default_mesh_path()) if with_mesh else None
    scene_nodes = [] if source is None else [_add_body(gltf, out, skeleton, source)]
    ball = None
    if any(t.ball_times is not None for t in takes):
        ball = _add_ball(gltf, out, source)
        scene_nodes.append(ball)
    roots = [int(i) for i in np.nonzero(skeleton.parents < 0)[0]]
    gltf.nodes.append(g.Node(name=character, children=roots, extras=_summary(takes)))
    scene_nodes.insert(0, len(gltf.nodes) - 1)
    if gltf.skins:
        gltf.skins[0].skeleton = len(gltf.nodes) - 1   # the character's root: the armature in importers
    for take in takes:
        _add_animation(gltf, out, skeleton, take, ball)
    gltf.scenes = [g.Scene(name=character, nodes=scene_nodes, extras=_summary(takes))]
    gltf.buffers = [g.Buffer(byteLength=len(out.blob))]
    gltf.set_binary_blob(bytes(out.blob))
    return gltf


def write_gltf(path: str | Path, skeleton: Skeleton, takes: Clip | list[Take], mesh_path: str | Path | None = None,
               with_mesh: bool = True, name: str | None = None) -> Path:
    """Write ``.glb`` or ``.gltf`` (buffer embedded) atomically; returns the path.
    ``takes``: a list of :class:`Take` or one clip (named ``name``, default the
    file's stem). A bad extension, a missing folder or a bad clip raises before
    anything is written."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in EXTENSIONS:
        raise ValueError(f"{path}: unknown glTF extension {path.suffix or '(none)'!r} (use .glb or .gltf)")
    import pygltflib as g
    gltf = build_gltf(skeleton, takes, mesh_path, with_mesh, name or path.stem)
    with atomic_output(path) as tmp:
        if suffix == ".glb":
            gltf.save_binary(str(tmp))
        else:
            gltf.convert_buffers(g.BufferFormat.DATAURI)
            gltf.save_json(str(tmp))
    return path
