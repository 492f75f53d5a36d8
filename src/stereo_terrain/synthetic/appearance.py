"""Appearance: procedural texture tiles, mip-maps, per-face materials and shading."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .geometry import _BOX_OBSTACLE, _FACE_BOX0, _Geometry
from .spec import _GROUPS, SceneSpec, SurfaceSpec

#: Side of a square texture tile in texels (a power of two, so wrapping is a bit mask).
_TILE_PX = 512

# Face-coordinate modes: which two coordinates (metres) a texture is laid out on.
_MODE_XY, _MODE_BA, _MODE_BZ, _MODE_AZ = 0, 1, 2, 3


# --------------------------------------------------------------------------- textures


def _fft_filter(img: np.ndarray, amp: np.ndarray) -> np.ndarray:
    return np.fft.irfft2(np.fft.rfft2(img) * amp, s=img.shape)


def _freqs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Spatial frequencies (cycles per tile) along rows (t) and columns (s)."""
    return np.fft.fftfreq(n)[:, None] * n, np.fft.rfftfreq(n)[None, :] * n


def _spectral_noise(
    rng: np.random.Generator, n: int, beta: float, *, stretch: float = 1.0, f_hi: float | None = None
) -> np.ndarray:
    """Periodic noise with amplitude spectrum ``k^-beta`` (multi-scale, like summed octaves
    of value noise). ``stretch > 1`` elongates features along the tile's s axis."""
    ky, kx = _freqs(n)
    k = np.sqrt((kx * stretch) ** 2 + ky**2)
    with np.errstate(divide="ignore"):
        amp = np.where(k > 0, k ** (-beta), 0.0)
    if f_hi is not None:
        amp *= np.exp(-((k / f_hi) ** 2))
    out = _fft_filter(rng.standard_normal((n, n)), amp)
    return (out - out.mean()) / (out.std() + 1e-12)


def _gauss_blur_periodic(img: np.ndarray, sigma_px: float) -> np.ndarray:
    ky, kx = _freqs(img.shape[0])
    n = img.shape[0]
    amp = np.exp(-2.0 * (math.pi * sigma_px / n) ** 2 * (kx**2 + ky**2))
    return _fft_filter(img, amp)


def _make_tile(kind: str, rng: np.random.Generator, n: int = _TILE_PX) -> np.ndarray:
    """A periodic texture tile, zero mean, unit std, float32 (rows: t, columns: s)."""
    if kind == "noise":
        tile = _spectral_noise(rng, n, rng.uniform(0.8, 1.3))
    elif kind == "carpet":
        fibres = _spectral_noise(rng, n, 0.15, f_hi=n / 3.0)
        tile = 0.8 * fibres + 0.5 * _spectral_noise(rng, n, 1.1)
    elif kind == "wood":
        rows = np.arange(n)[:, None] / n
        warp = _spectral_noise(rng, n, 1.6, stretch=4.0)
        rings = np.sin(2 * math.pi * (rng.integers(6, 16) * rows + 0.25 * warp))
        rings = np.sign(rings) * np.abs(rings) ** 0.6
        grain = _spectral_noise(rng, n, 0.7, stretch=12.0)
        n_planks = int(rng.choice([2, 4]))
        plank = (np.arange(n) * n_planks // n)[:, None]
        plank_tone = rng.normal(0.0, 0.6, n_planks)[plank]
        seam = ((np.arange(n) % (n // n_planks)) < 3)[:, None]
        tile = 0.5 * rings + 0.6 * grain + plank_tone - 2.5 * seam
        tile = _gauss_blur_periodic(np.broadcast_to(tile, (n, n)).astype(np.float64), 0.7)
    elif kind == "tiles":
        m = int(rng.choice([2, 4]))
        idx = np.arange(n) * m // n
        tone = rng.normal(0.0, 0.5, (m, m))[idx[:, None], idx[None, :]]
        g = max(2, n // m // 25)
        grout = (np.arange(n) % (n // m)) < g
        tile = tone + 0.5 * _spectral_noise(rng, n, 0.9) - 3.0 * (grout[:, None] | grout[None, :])
        tile = _gauss_blur_periodic(tile, 0.8)
    elif kind == "speckle":
        dots = (rng.random((n, n)) < 0.03) * rng.choice([-1.0, 1.0], (n, n), p=[0.65, 0.35])
        dots = _gauss_blur_periodic(dots, rng.uniform(0.7, 1.5))
        dots /= dots.std() + 1e-12
        tile = dots + 0.4 * _spectral_noise(rng, n, 1.2)
    elif kind == "planks":
        # Floorboards along the tile's s axis (horizontal on treads and risers): a tone
        # per board, fine grain stretched along it, dark gaps between boards and a few
        # butt joints across them.
        n_boards = int(rng.choice([4, 6, 8]))
        board = (np.arange(n) * n_boards // n)[:, None]
        tone = rng.normal(0.0, 0.5, n_boards)[board]
        grain = _spectral_noise(rng, n, 0.9, stretch=25.0)
        streaks = _spectral_noise(rng, n, 1.5, stretch=8.0)
        gap_px = max(2, n // 170)
        gap = ((np.arange(n) % (n // n_boards)) < gap_px)[:, None]
        joints = np.zeros((n, n), dtype=bool)
        for bi in range(n_boards):
            for s_j in rng.integers(0, n, int(rng.integers(0, 2))):
                band = slice(bi * n // n_boards, (bi + 1) * n // n_boards)
                joints[band, s_j : s_j + gap_px] = True
        tile = tone + 0.45 * grain + 0.35 * streaks - 4.0 * (gap | joints)
        tile = _gauss_blur_periodic(np.broadcast_to(tile, (n, n)).astype(np.float64), 0.6)
    elif kind == "paint":
        # Painted plaster or wood: slow blotches of the roller and a faint fine stipple.
        tile = _spectral_noise(rng, n, 1.8) + 0.35 * _spectral_noise(rng, n, 0.3, f_hi=n / 6.0)
    else:  # pragma: no cover - SurfaceSpec validates the kind
        raise InputError(f"unknown texture kind {kind!r}")
    tile = (tile - tile.mean()) / (tile.std() + 1e-12)
    return np.clip(tile, -3.5, 3.5).astype(np.float32)


@dataclass(frozen=True)
class _Pyramid:
    """A mip-map of a square periodic tile, all levels in one flat array."""

    data: np.ndarray  # float32, concatenated levels
    offsets: np.ndarray  # int32 (L,), start of each level in ``data``
    sizes: np.ndarray  # int32 (L,), side of each level in texels
    scales: np.ndarray  # float32 (L,), 2 ** -level
    n: int

    @classmethod
    def build(cls, tile: np.ndarray) -> _Pyramid:
        levels = [tile]
        while levels[-1].shape[0] > 1:
            t = levels[-1]
            h = t.shape[0] // 2
            levels.append(t.reshape(h, 2, h, 2).mean(axis=(1, 3)))
        counts = np.array([lv.size for lv in levels])
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int32)
        sizes = np.array([lv.shape[0] for lv in levels], dtype=np.int32)
        data = np.concatenate([lv.ravel() for lv in levels]).astype(np.float32)
        scales = (sizes / tile.shape[0]).astype(np.float32)
        return cls(data, offsets, sizes, scales, tile.shape[0])

    def bilinear(self, s: np.ndarray, t: np.ndarray, level: np.ndarray) -> np.ndarray:
        """Bilinear lookup at wrapped level-0 texel coordinates in level ``level`` (int32)."""
        size = self.sizes[level]
        scale = self.scales[level]
        x = s * scale - np.float32(0.5)
        y = t * scale - np.float32(0.5)
        x0 = np.floor(x)
        y0 = np.floor(y)
        wx = x - x0
        wy = y - y0
        mask = size - 1
        ix0 = x0.astype(np.int32) & mask
        iy0 = y0.astype(np.int32) & mask
        ix1 = (ix0 + 1) & mask
        row0 = self.offsets[level] + iy0 * size
        row1 = self.offsets[level] + ((iy0 + 1) & mask) * size
        d = self.data
        a, b = d[row0 + ix0], d[row0 + ix1]
        c, e = d[row1 + ix0], d[row1 + ix1]
        top = a + wx * (b - a)
        bot = c + wx * (e - c)
        return top + wy * (bot - top)

    def sample(self, s: np.ndarray, t: np.ndarray, lod: np.ndarray) -> np.ndarray:
        """Trilinear sample at level-0 texel coordinates ``(s, t)`` and level ``lod``."""
        top = len(self.offsets) - 1
        lod = np.clip(lod, np.float32(0.0), np.float32(top - 1e-3))
        l0 = lod.astype(np.int32)  # floor: lod >= 0
        w = (lod - l0).astype(np.float32)
        # Wrap first: float32 then keeps sub-texel precision far from the origin.
        s = np.mod(s, self.n).astype(np.float32)
        t = np.mod(t, self.n).astype(np.float32)
        v0 = self.bilinear(s, t, l0)
        v1 = self.bilinear(s, t, l0 + 1)
        return v0 + w * (v1 - v0)


@dataclass(frozen=True)
class _Appearance:
    """Per-face lookup tables and per-group texture pyramids."""

    base: np.ndarray  # (F,) float32: exposure * albedo * shade (grey levels)
    contrast: np.ndarray  # (F,) float32
    group: np.ndarray  # (F,) int: index into _GROUPS, -1 for the sky
    mode: np.ndarray  # (F,) int: face-coordinate mode
    offset: np.ndarray  # (F, 2) float32: texture offset, metres
    pyramids: dict  # group index -> _Pyramid
    tile_m: dict  # group index -> metres per tile
    ground_axes: tuple[np.float32, np.float32]  # cos, sin of the ground texture's rotation
    # Nosing strips (None: none): (F,) float32 front edge ``a`` of each tread face and top
    # ``z`` of each riser face (-inf, +inf elsewhere), their depth and reflectance factor.
    nose_a: np.ndarray | None = None
    nose_z: np.ndarray | None = None
    nosing_m: float = 0.0
    nosing_reflectance: float = 1.0
    texture_origin: tuple[float, float] = (0.0, 0.0)  # frame (x, y) textures count from

    @property
    def key(self) -> np.ndarray:
        """(F,) uint8: 0 for the sky, else 1 + 4 * group + mode."""
        k = 1 + 4 * self.group + self.mode
        k[self.group < 0] = 0
        return k.astype(np.uint8)

    @property
    def n_keys(self) -> int:
        return 1 + 4 * len(_GROUPS)


def _face_table(geom: _Geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, 3) normals (yaw frame), group index and coordinate mode of every face id."""
    c, s = geom.cos_yaw, geom.sin_yaw
    u = np.array([c, s, 0.0])
    v = np.array([-s, c, 0.0])
    up = np.array([0.0, 0.0, 1.0])
    g = {name: i for i, name in enumerate(_GROUPS)}
    normals = [np.zeros(3), up, -u]
    groups = [-1, g["ground"], g["wall"]]
    modes = [_MODE_XY, _MODE_XY, _MODE_BZ]
    box_modes = [_MODE_BZ, _MODE_BZ, _MODE_AZ, _MODE_AZ, _MODE_BA, _MODE_BA]
    for i in range(geom.n_boxes):
        normals += [-u, u, -v, v, -up, up]
        if geom.box_kind is None or geom.box_kind[i] == _BOX_OBSTACLE:
            groups += [g["riser"], g["side"], g["side"], g["side"], g["side"], g["tread"]]
        else:
            groups += [g["wall"]] * 6
        modes += box_modes
    for j in range(geom.n_rails):
        slope = float(geom.rails[j, 6]) if geom.rails is not None else 0.0
        top = (up - slope * u) / math.hypot(1.0, slope)
        normals += [-u, u, -v, v, -top, top]
        groups += [g["rail"]] * 6
        modes += box_modes
    return np.array(normals), np.array(groups), np.array(modes)


def _nosing_tables(geom: _Geometry, n_faces: int) -> tuple[np.ndarray, np.ndarray]:
    """(F,) front edge ``a`` of tread faces (-inf elsewhere) and top ``z`` of riser faces
    (+inf elsewhere): no strip off those faces."""
    nose_a = np.full(n_faces, -np.inf, dtype=np.float32)
    nose_z = np.full(n_faces, np.inf, dtype=np.float32)
    for i in range(geom.n_obstacle_boxes):
        nose_a[_FACE_BOX0 + 6 * i + 5] = geom.boxes[i, 0]
        nose_z[_FACE_BOX0 + 6 * i + 0] = geom.boxes[i, 5]
    return nose_a, nose_z


def _appearance(spec: SceneSpec, geom: _Geometry) -> _Appearance:
    normals, groups, modes = _face_table(geom)
    el, az = spec.light_elevation_rad, spec.light_azimuth_rad
    light = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    shade = spec.ambient + spec.diffuse * np.maximum(normals @ light, 0.0)
    rng = np.random.default_rng([spec.seed, 1])
    n_faces = len(groups)
    # The faces of the ground, back wall and obstacle draw from one stream, those of side
    # walls and rails from another: adding walls or rails leaves the stairs' textures.
    n_base = _FACE_BOX0 + 6 * geom.n_obstacle_boxes
    jitter = 1.0 + rng.uniform(-0.04, 0.04, n_base)  # e.g. each step's paint a little apart
    offset = rng.uniform(0.0, 10.0, (n_base, 2))
    ground_angle = rng.uniform(math.radians(30.0), math.radians(60.0))
    if n_faces > n_base:
        # One row per face: the draws of a face do not depend on how many follow it.
        extra = np.random.default_rng([spec.seed, 4]).random((n_faces - n_base, 3))
        jitter = np.concatenate([jitter, 1.0 + 0.08 * (extra[:, 0] - 0.5)])
        offset = np.concatenate([offset, 10.0 * extra[:, 1:]])
    albedo = np.ones(n_faces)
    contrast = np.zeros(n_faces)
    for gi, name in enumerate(_GROUPS):
        surf: SurfaceSpec = getattr(spec, name)
        albedo[groups == gi] = surf.albedo
        contrast[groups == gi] = surf.contrast
    # Stair sides share one texture layout so that the side of the flight has no seams.
    side = groups == _GROUPS.index("side")
    if side.any():
        offset[side] = offset[np.argmax(side)]
        jitter[side] = 1.0
    base = spec.exposure * np.minimum(albedo * jitter, 1.0) * shade
    base[0] = spec.sky_grey
    present = sorted(set(int(x) for x in groups[1:]))
    nose_a, nose_z = _nosing_tables(geom, n_faces) if spec.nosing_m > 0 else (None, None)
    pyramids, tile_m = {}, {}
    for gi in present:
        surf = getattr(spec, _GROUPS[gi])
        trng = np.random.default_rng([spec.seed, 2, gi])
        pyramids[gi] = _Pyramid.build(_make_tile(surf.texture, trng))
        tile_m[gi] = surf.tile_m
    return _Appearance(
        base.astype(np.float32),
        contrast.astype(np.float32),
        groups,
        modes,
        offset.astype(np.float32),
        pyramids,
        tile_m,
        (np.float32(math.cos(ground_angle)), np.float32(math.sin(ground_angle))),
        nose_a,
        nose_z,
        float(spec.nosing_m),
        float(spec.nosing_reflectance),
        (float(spec.texture_origin_m[0]), float(spec.texture_origin_m[1])),
    )


#: Height of the nosing strip seen on the top of a riser, metres (at most nosing_m).
_NOSING_FRONT_M = 0.025


#: A second, larger and rotated copy of the texture modulates large surfaces (ground,
#: wall) so that the tile's period does not show in the far field.
_MACRO_SCALE = 1.0 / 6.3
_MACRO_ANGLE = math.radians(37.0)
_MACRO_WEIGHT = 0.6
_MACRO_MIN_LEVEL = 3


def _shade(
    origin: np.ndarray,
    dx: np.ndarray,
    dy: np.ndarray,
    dz: np.ndarray,
    t: np.ndarray,
    face: np.ndarray,
    geom: _Geometry,
    app: _Appearance,
    focal_px: float,
    samples_per_side: int,
) -> np.ndarray:
    """Radiance (grey levels, float32) of each sample from its hit."""
    out = app.base[face]
    ox, oy, oz = (float(v) for v in origin)
    # Sort the samples once by (group, coordinate mode): each run is textured at once.
    key = app.key[face]
    order = np.argsort(key, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(key, minlength=app.n_keys))])
    # Angular size of one sample; the footprint on the surface picks the mip level.
    sample_rad = np.float32(1.0 / (focal_px * samples_per_side))
    cm, sm = np.float32(math.cos(_MACRO_ANGLE)), np.float32(math.sin(_MACRO_ANGLE))
    for k in range(1, app.n_keys):
        if bounds[k + 1] == bounds[k]:
            continue
        gi, m = divmod(k - 1, 4)
        pyr = app.pyramids[gi]
        idx = order[bounds[k] : bounds[k + 1]]
        ti = t[idx]
        ddx, ddy, ddz = dx[idx], dy[idx], dz[idx]
        px, py, pz = ox + ti * ddx, oy + ti * ddy, oz + ti * ddz
        # Texture coordinates count from the textures' origin (SceneSpec.texture_origin_m).
        qx, qy = px - np.float32(app.texture_origin[0]), py - np.float32(app.texture_origin[1])
        if m == _MODE_XY:
            # Ground texture axes at an oblique angle to x: far pixels average long runs
            # along the view direction, which must not follow the tile's rows.
            gc, gs = app.ground_axes
            cs, ct, cos_n = gc * qx - gs * qy, gs * qx + gc * qy, np.abs(ddz)
        else:
            pa, pb = geom.to_local(px, py)  # the nosing strips are placed in these
            qa, qb = geom.to_local(qx, qy)
            da, db = geom.to_local(ddx, ddy)
            if m == _MODE_BA:
                cs, ct, cos_n = qb, qa, np.abs(ddz)
            elif m == _MODE_BZ:
                cs, ct, cos_n = qb, pz, np.abs(da)
            else:
                cs, ct, cos_n = qa, pz, np.abs(db)
        norm = np.sqrt(ddx * ddx + ddy * ddy + ddz * ddz)
        cos_n = np.maximum(cos_n / norm, np.float32(0.05))
        texel_m = np.float32(app.tile_m[gi] / pyr.n)
        footprint = ti * norm * sample_rad / np.sqrt(cos_n)
        lod = np.log2(np.maximum(footprint / texel_m, np.float32(1e-6)))
        fi = face[idx]
        off = app.offset[fi]
        scale = np.float32(pyr.n / app.tile_m[gi])
        u = (cs + off[:, 0]) * scale
        v = (ct + off[:, 1]) * scale
        tex = pyr.sample(u, v, lod)
        if _GROUPS[gi] in ("ground", "wall"):
            mu = (cm * u - sm * v) * np.float32(_MACRO_SCALE)
            mv = (sm * u + cm * v) * np.float32(_MACRO_SCALE)
            # Low-frequency layer: one bilinear lookup at a coarse level is enough.
            level = np.clip(
                np.rint(lod + np.float32(math.log2(_MACRO_SCALE))), _MACRO_MIN_LEVEL, len(pyr.offsets) - 1
            ).astype(np.int32)
            macro = pyr.bilinear(np.mod(mu, pyr.n), np.mod(mv, pyr.n), level)
            tex = (tex + np.float32(_MACRO_WEIGHT) * macro) * np.float32(1.0 / math.hypot(1.0, _MACRO_WEIGHT))
        refl = np.maximum(1.0 + app.contrast[fi] * tex, np.float32(0.05))
        if app.nose_a is not None and app.nose_z is not None and m in (_MODE_BA, _MODE_BZ):
            # A strip (nosing, edge tape) along the front edge of each tread and down the
            # top of the riser below it.
            if m == _MODE_BA:
                strip = pa - app.nose_a[fi] < np.float32(app.nosing_m)
            else:
                strip = app.nose_z[fi] - pz < np.float32(min(app.nosing_m, _NOSING_FRONT_M))
            refl = np.where(strip, refl * np.float32(app.nosing_reflectance), refl)
        out[idx] *= refl
    return out
