"""A MuJoCo scene as Rerun 3-D entities (``world/scene/{body}/{geom}``): :class:`SceneGeometry`."""

from __future__ import annotations

import numpy as np
import rerun as rr

#: MuJoCo geom groups drawn in the 3-D view (MuJoCo's visible-by-default groups; 1 = the head).
SCENE_GEOM_GROUPS = (0, 1, 2)
#: A plane is drawn as a box of this half-thickness (m); an infinite plane (size 0) this half-extent.
PLANE_HALF_THICKNESS = 0.0005
INFINITE_PLANE_HALF_EXTENT = 5.0
#: A pose (translation in m, rotation-matrix entries) is logged again once it moved by more than this
#: (Rerun stores them as float32: about 1e-7 at the scale of a metre).
POSE_TOLERANCE = 1e-7
_DEFAULT_GEOM_RGBA = np.array([0.5, 0.5, 0.5, 1.0], np.float32)  # MuJoCo's: a material's colour wins


def _quat_to_mat(q) -> np.ndarray:
    """Unit quaternion (w, x, y, z) -> rotation matrix (child -> parent coordinates)."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _rgba_u8(rgba) -> np.ndarray:
    return (np.clip(np.asarray(rgba, float), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _part(name: str, kind: str, i: int) -> str:
    return rr.escape_entity_path_part(name) if name else f"{kind}_{i}"


class SceneGeometry:
    """A MuJoCo model's visible geoms as Rerun entities under ``root`` (default ``world/scene``).

    One entity per body that has geoms, ``{root}/{body}``, holding the body's world pose; one per
    geom, ``{root}/{body}/{geom}``, holding its pose in the body and its shape and colour (see the
    entity tree in :mod:`experiments.recording`). :meth:`log` logs what is new or changed since its
    last call: body poses from ``data`` that moved by more than ``POSE_TOLERANCE`` (mocap objects,
    the turning head and eyes) and geoms whose type, size, pose, colour or material changed in the
    model (a flash switched on or off through its alpha, a resized dot).
    Geom types hfield and sdf are not drawn (none of the scenes has them).
    """

    def __init__(self, model, root: str = "world/scene") -> None:
        import mujoco  # imported by models before any model exists

        G = mujoco.mjtGeom
        self._kinds = {
            int(G.mjGEOM_PLANE): "plane",
            int(G.mjGEOM_SPHERE): "sphere",
            int(G.mjGEOM_CAPSULE): "capsule",
            int(G.mjGEOM_ELLIPSOID): "ellipsoid",
            int(G.mjGEOM_CYLINDER): "cylinder",
            int(G.mjGEOM_BOX): "box",
            int(G.mjGEOM_MESH): "mesh",
        }
        self._rgb_role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
        self.model = model
        m = model
        self.geoms = np.array(
            [
                g
                for g in range(m.ngeom)
                if int(m.geom_group[g]) in SCENE_GEOM_GROUPS and int(m.geom_type[g]) in self._kinds
            ],
            dtype=int,
        )
        self.bodies = np.unique(m.geom_bodyid[self.geoms]).astype(int) if len(self.geoms) else np.zeros(0, int)
        self.body_paths = {int(b): f"{root}/{_part(m.body(int(b)).name, 'body', int(b))}" for b in self.bodies}
        self.geom_paths = {
            int(g): self.body_paths[int(m.geom_bodyid[g])] + "/" + _part(m.geom(int(g)).name, "geom", int(g))
            for g in self.geoms
        }
        self._tex_mean: dict[int, np.ndarray] = {}
        self._body_key: np.ndarray | None = None
        self._geom_key: np.ndarray | None = None

    def reset(self) -> None:
        """Forget what was logged: the next :meth:`log` logs everything again."""
        self._body_key = self._geom_key = None

    # ------------------------------------------------------------------ geometry and colour
    def kind(self, gid: int) -> str:
        """``plane``, ``sphere``, ``capsule``, ``ellipsoid``, ``cylinder``, ``box`` or ``mesh``."""
        return self._kinds[int(self.model.geom_type[gid])]

    def _texture_mean(self, tex: int) -> np.ndarray:
        if tex not in self._tex_mean:
            m = self.model
            n = int(m.tex_height[tex]) * int(m.tex_width[tex]) * int(m.tex_nchannel[tex])
            px = np.asarray(m.tex_data[m.tex_adr[tex] : m.tex_adr[tex] + n], float).reshape(
                -1, int(m.tex_nchannel[tex])
            )
            rgb = px[:, :3].mean(axis=0) / 255.0 if px.shape[1] >= 3 else np.repeat(px.mean() / 255.0, 3)
            self._tex_mean[tex] = np.append(rgb, 1.0)
        return self._tex_mean[tex]

    def color(self, gid: int) -> np.ndarray:
        """The geom's RGBA as uint8: its ``rgba``, or, when that is MuJoCo's default and it has a
        material, the material's rgba times the mean colour of the material's RGB texture."""
        m = self.model
        rgba = np.asarray(m.geom_rgba[gid], float)
        mat = int(m.geom_matid[gid])
        if mat >= 0 and np.allclose(rgba, _DEFAULT_GEOM_RGBA):
            rgba = np.asarray(m.mat_rgba[mat], float)
            texid = np.atleast_1d(m.mat_texid[mat])
            tex = int(texid[self._rgb_role]) if texid.size > self._rgb_role else int(texid[0])
            if tex >= 0:
                rgba = rgba * self._texture_mean(tex)
        return _rgba_u8(rgba)

    def archetype(self, gid: int):
        """The Rerun shape of geom ``gid`` in its own frame (an empty batch when alpha is 0)."""
        m = self.model
        kind, size, c = self.kind(gid), np.asarray(m.geom_size[gid], float), self.color(gid)
        hidden = c[3] == 0  # alpha 0 (of the geom, or of its material): not drawn by MuJoCo either
        n = 0 if hidden else 1
        if kind in ("box", "plane"):
            half = size.copy()
            if kind == "plane":
                half = np.array(
                    [size[0] or INFINITE_PLANE_HALF_EXTENT, size[1] or INFINITE_PLANE_HALF_EXTENT, PLANE_HALF_THICKNESS]
                )
            return rr.Boxes3D(half_sizes=np.reshape(half, (1, 3))[:n], colors=[c][:n], fill_mode="solid")
        if kind in ("sphere", "ellipsoid"):
            half = np.repeat(size[0], 3) if kind == "sphere" else size
            return rr.Ellipsoids3D(half_sizes=np.reshape(half, (1, 3))[:n], colors=[c][:n], fill_mode="solid")
        if kind == "capsule":  # Rerun's runs from its origin along +z; MuJoCo's is centred
            return rr.Capsules3D(
                lengths=[2 * size[1]][:n],
                radii=[size[0]][:n],
                translations=[[0.0, 0.0, -size[1]]][:n],
                colors=[c][:n],
                fill_mode="solid",
            )
        if kind == "cylinder":
            return rr.Cylinders3D(
                lengths=[2 * size[1]][:n],
                radii=[size[0]][:n],
                centers=[[0.0, 0.0, 0.0]][:n],
                colors=[c][:n],
                fill_mode="solid",
            )
        mesh = int(m.geom_dataid[gid])  # mesh vertices are stored in the geom's frame
        va, vn = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
        fa, fn = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
        verts = np.asarray(m.mesh_vert[va : va + vn], np.float32)
        faces = np.asarray(m.mesh_face[fa : fa + fn], np.uint32)
        if hidden:
            verts, faces = verts[:0], faces[:0]
        return rr.Mesh3D(vertex_positions=verts, triangle_indices=faces, albedo_factor=c)

    # ------------------------------------------------------------------ logging
    def log(self, rec: rr.RecordingStream, data) -> int:
        """Log new or changed body poses and geoms at ``rec``'s current time; returns how many
        entities were logged."""
        m, n = self.model, 0
        b = self.bodies
        key = np.concatenate([data.xpos[b], data.xmat[b]], axis=1)
        if self._body_key is None:
            self._body_key = key.copy()
            changed = np.ones(len(b), bool)
        else:
            changed = np.any(np.abs(key - self._body_key) > POSE_TOLERANCE, axis=1)
        for i in np.flatnonzero(changed):
            rec.log(self.body_paths[int(b[i])], rr.Transform3D(translation=key[i, :3], mat3x3=key[i, 3:].reshape(3, 3)))
            self._body_key[i] = key[i]
            n += 1
        g = self.geoms
        mat = m.geom_matid[g]
        mat_rgba = np.vstack([np.asarray(m.mat_rgba, float).reshape(-1, 4), np.zeros((1, 4))])  # [-1]: none
        gkey = np.concatenate(
            [
                m.geom_type[g][:, None],
                m.geom_size[g],
                m.geom_pos[g],
                m.geom_quat[g],
                m.geom_rgba[g],
                mat[:, None],
                mat_rgba[mat],
            ],
            axis=1,
        )
        changed = np.ones(len(g), bool) if self._geom_key is None else np.any(gkey != self._geom_key, axis=1)
        for i in np.flatnonzero(changed):
            gid = int(g[i])
            path = self.geom_paths[gid]
            rec.log(path, rr.Transform3D(translation=m.geom_pos[gid], mat3x3=_quat_to_mat(m.geom_quat[gid])))
            rec.log(path, self.archetype(gid))
            n += 1
        self._geom_key = gkey
        return n
