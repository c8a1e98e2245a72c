"""Export a clip as glTF 2.0 with the skinned batsman, for Blender, three.js,
game engines: ``write_gltf(path, skeleton, clip)`` writes ``.glb`` (binary) or
``.gltf`` (JSON with the buffer embedded as a data URI), atomically.

What the file holds:

* the joints as nodes in the skeleton's order (``parents[i] < i``), rest
  translation = ``skeleton.offsets`` in cm, no rest rotation (rest frames are
  world-aligned, as everywhere in Hitpoint);
* the ``Batsman`` skinned mesh and its skin copied byte for byte from
  ``assets/batsman.glb`` (positions in cm; the skin's inverse bind matrices
  are translations by the negated bind positions); the skin's joints are
  matched to the skeleton by name;
* one animation: a rotation channel per joint ((x,y,z,w) quaternions, glTF's
  order; Hitpoint's own arrays are (w,x,y,z)), a translation channel on the
  root (and on any joint whose clip animates its translation), LINEAR
  samplers, key times ``frame / fps`` seconds.

Units: glTF tools assume metres. The data stay in cm (the bundled mesh is
authored in cm, so its vertices and inverse bind matrices need no rewrite) and
the joint hierarchy hangs under one node ``cm_to_m`` with scale 0.01, so the
batsman imports 1.8 m tall. The skinned mesh node sits at the scene root
(glTF ignores a skinned mesh node's own transform; the joints carry the scale).
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from . import quat
from .atomic import atomic_output
from .skeleton import Clip, Skeleton, bind_positions, local_translations

EXTENSIONS = (".glb", ".gltf")
METRES_PER_CM = 0.01
SCALE_NODE_NAME = "cm_to_m"
MESH_NAME = "Batsman"

# glTF constants (the spec's numbers; pygltflib names them the same)
_FLOAT, _ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 5126, 34962, 34963
# Standard attributes carried over; app-specific ones (``_GLOSS``) stay behind.
_ATTRIBUTES = ("POSITION", "NORMAL", "COLOR_0", "JOINTS_0", "WEIGHTS_0")
# Bind positions of the mesh's skin and of the skeleton must agree this well (cm).
_BIND_TOLERANCE_CM = 1e-3


def default_mesh_path() -> Path:
    from .rig import assets_dir
    return assets_dir() / "batsman.glb"


class _Buffer:
    """One binary buffer being filled: bufferViews and accessors appended as we go."""

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

    def accessor(self, array: np.ndarray, kind: str, minmax: bool = False) -> int:
        """A float32 accessor over ``array (N,)`` or ``(N, k)``; returns its index."""
        import pygltflib as g
        a = np.ascontiguousarray(array, np.float32)
        acc = g.Accessor(bufferView=self.view(a.tobytes()), componentType=_FLOAT, count=len(a), type=kind)
        if minmax:  # required on animation inputs
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
def _copy_accessor(src, src_blob: bytes, index: int, out: _Buffer, memo: dict) -> int:
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


def _mesh_skin_names(src) -> tuple[int, object, list[str]]:
    """(mesh index, skin, skin joint names) of the ``Batsman`` mesh in ``src``."""
    for node in src.nodes:
        if node.mesh is not None and src.meshes[node.mesh].name == MESH_NAME and node.skin is not None:
            skin = src.skins[node.skin]
            return node.mesh, skin, [src.nodes[j].name for j in skin.joints]
    raise ValueError(f"no skinned mesh {MESH_NAME!r} in the mesh file")


def _check_bind(src, src_blob: bytes, skin, names: list[str], skeleton: Skeleton, where) -> None:
    """The mesh was bound to this skeleton's rest pose (else it would shear)."""
    if skin.inverseBindMatrices is None:
        return
    acc = src.accessors[skin.inverseBindMatrices]
    start = (src.bufferViews[acc.bufferView].byteOffset or 0) + (acc.byteOffset or 0)
    ibm = np.frombuffer(src_blob, np.float32, 16 * acc.count, start).reshape(-1, 4, 4)  # column-major
    want = np.tile(np.eye(4), (len(names), 1, 1))    # world-aligned rest frames: a pure translation
    want[:, 3, :3] = -bind_positions(skeleton)[[skeleton.names.index(n) for n in names]]
    err = np.abs(ibm - want).max(axis=(1, 2))
    if err.max() > _BIND_TOLERANCE_CM:
        j = int(err.argmax())
        raise ValueError(f"{where}: the mesh is bound to another rest pose (joint {names[j]!r} "
                         f"{err[j]:.3g} cm off); export without the mesh")


def _add_mesh(gltf, out: _Buffer, skeleton: Skeleton, mesh_path: Path) -> int:
    """Copy the skinned batsman (mesh, material, skin) into ``gltf``; returns its node index."""
    import pygltflib as g
    src = g.GLTF2().load(str(mesh_path))
    src_blob = src.binary_blob()
    if src_blob is None:
        raise ValueError(f"{mesh_path}: no binary buffer (expected a .glb)")
    mesh_index, skin, names = _mesh_skin_names(src)
    missing = [n for n in names if n not in skeleton.names]
    if missing:
        raise ValueError(f"{mesh_path}: skin joint {missing[0]!r} is not in the skeleton")
    _check_bind(src, src_blob, skin, names, skeleton, mesh_path)
    memo: dict = {}
    materials: dict = {}
    prims = [_copy_primitive(gltf, src, src_blob, p, out, memo, materials) for p in src.meshes[mesh_index].primitives]
    gltf.meshes.append(g.Mesh(name=MESH_NAME, primitives=prims))
    joints = [skeleton.names.index(n) for n in names]      # joint nodes are 0..J-1 in skeleton order
    ibm = None if skin.inverseBindMatrices is None else _copy_accessor(src, src_blob, skin.inverseBindMatrices, out, memo)
    gltf.skins.append(g.Skin(name="rig", joints=joints, inverseBindMatrices=ibm))
    gltf.nodes.append(g.Node(name=MESH_NAME, mesh=len(gltf.meshes) - 1, skin=0))
    return len(gltf.nodes) - 1


def _copy_primitive(gltf, src, src_blob: bytes, p, out: _Buffer, memo: dict, materials: dict):
    """One primitive of ``src`` with its standard attributes, indices and material."""
    import pygltflib as g
    attrs = g.Attributes(**{a: _copy_accessor(src, src_blob, getattr(p.attributes, a), out, memo)
                            for a in _ATTRIBUTES if getattr(p.attributes, a, None) is not None})
    if p.material is not None and p.material not in materials:
        gltf.materials.append(copy.deepcopy(src.materials[p.material]))
        materials[p.material] = len(gltf.materials) - 1
    indices = None if p.indices is None else _copy_accessor(src, src_blob, p.indices, out, memo)
    return g.Primitive(attributes=attrs, mode=p.mode, indices=indices, material=materials.get(p.material))


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


def _add_animation(gltf, out: _Buffer, skeleton: Skeleton, clip: Clip, name: str) -> None:
    import pygltflib as g
    F = clip.num_frames
    times = out.accessor(np.arange(F) / clip.fps, "SCALAR", minmax=True)
    samplers, channels = [], []

    def channel(node: int, path: str, values: np.ndarray, kind: str) -> None:
        samplers.append(g.AnimationSampler(input=times, output=out.accessor(values, kind), interpolation="LINEAR"))
        channels.append(g.AnimationChannel(sampler=len(samplers) - 1,
                                           target=g.AnimationChannelTarget(node=node, path=path)))

    rot = gltf_rotations(clip.local_rotations)
    for j in range(skeleton.num_joints):
        channel(j, "rotation", rot[:, j], "VEC4")
    moving, t = _animated_translations(skeleton, clip)
    for j in moving:
        channel(j, "translation", t[:, j], "VEC3")
    gltf.animations.append(g.Animation(name=name, samplers=samplers, channels=channels))


# ----------------------------------------------------------------- document
def _joint_nodes(skeleton: Skeleton) -> list:
    import pygltflib as g
    return [g.Node(name=n, translation=[float(x) for x in skeleton.offsets[i]],
                   children=skeleton.children(i) or None)
            for i, n in enumerate(skeleton.names)]


def build_gltf(skeleton: Skeleton, clip: Clip, mesh_path: str | Path | None = None, with_mesh: bool = True,
               name: str = "shot"):
    """The glTF document (``pygltflib.GLTF2`` with its binary blob set).

    Node order: joints ``0..J-1`` (skeleton order), then the mesh node, then the
    ``cm_to_m`` scale node holding the root joint(s).
    """
    import pygltflib as g
    check_clip(skeleton, clip)
    gltf = g.GLTF2(asset=g.Asset(version="2.0", generator="hitpoint engine/gltf_export.py"),
                   scene=0, nodes=_joint_nodes(skeleton))
    out = _Buffer(gltf)
    scene_nodes = []
    if with_mesh:
        scene_nodes.append(_add_mesh(gltf, out, skeleton, Path(mesh_path) if mesh_path else default_mesh_path()))
    roots = [int(i) for i in np.nonzero(skeleton.parents < 0)[0]]
    gltf.nodes.append(g.Node(name=SCALE_NODE_NAME, scale=[METRES_PER_CM] * 3, children=roots))
    scene_nodes.insert(0, len(gltf.nodes) - 1)
    if gltf.skins:
        gltf.skins[0].skeleton = len(gltf.nodes) - 1   # importers keep the scale with the armature
    _add_animation(gltf, out, skeleton, clip, name)
    gltf.scenes = [g.Scene(name=name, nodes=scene_nodes)]
    gltf.buffers = [g.Buffer(byteLength=len(out.blob))]
    gltf.set_binary_blob(bytes(out.blob))
    return gltf


def write_gltf(path: str | Path, skeleton: Skeleton, clip: Clip, mesh_path: str | Path | None = None,
               with_mesh: bool = True, name: str | None = None) -> Path:
    """Write ``.glb`` or ``.gltf`` (buffer embedded) atomically; returns the path.
    A bad extension, a missing folder or a bad clip raises before anything is written."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in EXTENSIONS:
        raise ValueError(f"{path}: unknown glTF extension {path.suffix or '(none)'!r} (use .glb or .gltf)")
    import pygltflib as g
    gltf = build_gltf(skeleton, clip, mesh_path, with_mesh, name or path.stem)
    with atomic_output(path) as tmp:
        if suffix == ".glb":
            gltf.save_binary(str(tmp))
        else:
            gltf.convert_buffers(g.BufferFormat.DATAURI)
            gltf.save_json(str(tmp))
    return path

