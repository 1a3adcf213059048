"""The v2 data's variety (render.py --split; docs/DETECTOR.md, "v2 data"):
body builds, garments, scene kinds with lamps, and a bystander, as the
Scene methods init_v2 and setup_v2.

Runs inside Blender (bpy).  Importing it adds the methods to scene.Scene.
"""
import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

from scene import (N_CLUTTER, SEGMENTS, Scene, make_material, random_colour,  # noqa: F401
                   segment_matrix, set_material, skin_colour)

# ------------------------------------------------------------------ v2 data
# Factors of the v2 data (render.py --split; docs/DETECTOR.md, "v2 data").
# Each kind belongs to one split only: no validation frame shares a build,
# a garment or a scene kind with training.
BUILDS = {"train": ("slight", "average", "broad"), "val": ("heavy",)}
GARMENTS = {"train": ("fitted", "short", "loose"), "val": ("sleeveless",)}
SCENE_KINDS = {"train": ("outdoor", "hall"), "val": ("room",)}
BYSTANDER_P = 0.4          # share of frames with a bystander
BYSTANDER_DIST = (1.0, 3.0)  # m, horizontal, pelvis to pelvis

# girth multipliers per segment (on top of SEGMENTS' radius), (low, high)
_LIMB = ("uarm", "farm", "thigh", "shin")


def build_girth(build, rng):
    """Per-segment radius factors and the torso's depth factor of a build."""
    if build == "slight":
        base = rng.uniform(0.74, 0.88)
        f = {n: base * (0.92 if any(k in n for k in _LIMB) else 1.0) for n, *_ in SEGMENTS}
        depth = rng.uniform(0.9, 1.0)
    elif build == "average":
        base = rng.uniform(0.9, 1.08)
        f = {n: base for n, *_ in SEGMENTS}
        depth = 1.0
    elif build == "broad":  # athletic: wide chest and shoulders, thick upper limbs, flat belly
        base = rng.uniform(0.98, 1.1)
        f = {n: base for n, *_ in SEGMENTS}
        for n, lo, hi in (("chest", 1.12, 1.28), ("shoulders", 1.15, 1.35), ("uarm", 1.15, 1.3),
                          ("thigh", 1.08, 1.2), ("farm", 1.05, 1.15)):
            k = rng.uniform(lo, hi)
            for m in f:
                if n in m:
                    f[m] = base * k
        depth = rng.uniform(0.95, 1.05)
    else:  # heavy: belly, wide hips and thighs, thick arms
        base = rng.uniform(1.0, 1.12)
        f = {n: base for n, *_ in SEGMENTS}
        for n, lo, hi in (("abdomen", 1.15, 1.35), ("chest", 1.08, 1.22), ("hips", 1.12, 1.3),
                          ("thigh", 1.15, 1.35), ("uarm", 1.12, 1.3), ("farm", 1.05, 1.2), ("shin", 1.05, 1.15)):
            k = rng.uniform(lo, hi)
            for m in f:
                if n in m:
                    f[m] = base * k
        depth = rng.uniform(1.15, 1.35)
    return f, depth


def garment_cut(garment, rng):
    """Radius factors per segment from the clothes (loose: wider, widest at
    the cuffs), and which segments show skin."""
    f = {n: 1.0 for n, *_ in SEGMENTS}
    if garment == "loose":
        for n, lo, hi in (("abdomen", 1.12, 1.3), ("chest", 1.08, 1.22), ("hips", 1.1, 1.25),
                          ("uarm", 1.25, 1.5), ("farm", 1.4, 1.8), ("thigh", 1.2, 1.4), ("shin", 1.35, 1.7)):
            k = rng.uniform(lo, hi)
            for m in f:
                if n in m:
                    f[m] = k
    sleeve = {"fitted": "long", "loose": "long", "short": "elbow", "sleeveless": "none"}[garment]
    longpants = rng.random() < (0.9 if garment == "loose" else 0.7)
    return f, sleeve, longpants


def _box_lamp_objects(sc, name):
    """A standing lamp: a pole, a glowing shade open at both ends and a
    point light in it."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=8, radius=0.5, depth=1)
    pole = bpy.context.active_object
    pole.name = name + "_pole"
    bpy.ops.mesh.primitive_cone_add(vertices=16, radius1=0.5, radius2=0.3, depth=1, end_fill_type="NOTHING")
    shade = bpy.context.active_object
    shade.name = name + "_shade"
    m = bpy.data.materials.new(name + "_shade")
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    em = nt.nodes.new("ShaderNodeEmission")
    dif = nt.nodes.new("ShaderNodeBsdfDiffuse")
    mix = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(em.outputs[0], mix.inputs[0])
    nt.links.new(dif.outputs[0], mix.inputs[1])
    nt.links.new(mix.outputs[0], out.inputs[0])
    shade.data.materials.append(m)
    try:  # the shade glows, but is not sampled as a light (noise at 8 samples)
        m.cycles.sample_as_light = False
    except AttributeError:
        m.cycles.emission_sampling = "NONE"
    pm = make_material(name + "_polemat")
    pole.data.materials.append(pm)
    ld = bpy.data.lights.new(name + "_light", "POINT")
    light = bpy.data.objects.new(name + "_light", ld)
    sc.collection.objects.link(light)
    return {"pole": pole, "shade": shade, "light": light, "em": em, "dif": dif, "polemat": pm}


def init_v2(self):
    """Extra objects of the v2 data: material slots for upper arms and the
    shoulder bar (sleeves), a bystander, furniture and standing lamps."""
    sc = self.sc
    for k in ("uarm", "shoulderwear"):
        self.mats[k] = make_material(k)
    for name in ("l_uarm", "r_uarm", "shoulders"):
        me = self.seg[name].data
        me.materials[0] = self.mats["shoulderwear" if name == "shoulders" else "uarm"]
    # bystander: the same ellipsoids plus a head, own clothes
    self.by_mats = {k: make_material("by_" + k) for k in ("shirt", "sleeve", "trousers", "legwear", "skin", "shoes")}
    self.by_seg = {}
    for name, a, b, r, mat in SEGMENTS + [("head", None, None, 0, "skin")]:
        me = self.sphere.copy()
        me.materials.clear()
        me.materials.append(self.by_mats[mat])
        ob = bpy.data.objects.new("by_" + name, me)
        sc.collection.objects.link(ob)
        self.by_seg[name] = ob
    # furniture (room)
    self.furniture = []
    for i in range(7):
        bpy.ops.mesh.primitive_cube_add(size=1)
        ob = bpy.context.active_object
        ob.name = "furniture%d" % i
        m = make_material("furniture%d" % i)
        ob.data.materials.append(m)
        self.furniture.append((ob, m))
    self.fixtures = [_box_lamp_objects(sc, "standlamp%d" % i) for i in range(3)]
    # extra ceiling/wall point lights (hall): three in all with self.lamps
    ld = bpy.data.lights.new("lamp2", "POINT")
    ob = bpy.data.objects.new("lamp2", ld)
    sc.collection.objects.link(ob)
    self.lamps.append(ob)


def _place_body(objs, J, g, fac, depth, head_ob=None, hr=None):
    """Ellipsoids of a posed body (as Scene.setup) with radius factors fac
    per segment (rng-free)."""
    Lax = J["left_shoulder"] - J["right_shoulder"]
    for name, a, b, r, mat in SEGMENTS:
        rad = r * g * fac[name]
        M, z = segment_matrix(J, name, a, b, Lax, rad, depth)
        if name == "abdomen" and depth > 1.05:  # a belly sticks out forwards
            fwd = np.cross(z, Lax / max(np.linalg.norm(Lax), 1e-6))
            fwd /= max(np.linalg.norm(fwd), 1e-6)
            M[:3, 3] = M[:3, 3] + fwd * rad * 0.75 * (depth - 1.0)
        objs[name].matrix_world = Matrix(M.tolist())
    if head_ob is not None:
        up = J["head_top"] - J["neck"]
        upn = up / max(np.linalg.norm(up), 1e-6)
        fwd = np.cross(upn, Lax)
        fwd = fwd / max(np.linalg.norm(fwd), 1e-6)
        x = np.cross(fwd, upn)
        M = np.eye(4)
        M[:3, 0], M[:3, 1], M[:3, 2] = x * hr * 0.95, fwd * hr * 1.1, upn * hr * 1.25
        M[:3, 3] = J["neck"] + 0.55 * up + 0.02 * g * fwd
        head_ob.matrix_world = Matrix(M.tolist())


def _extremities(J, g, toe_reach=0.35):
    """Hands and toe tips (geometry only: the labels stay the wrist and the
    toe base); toe_reach = how far the foot goes past the toe base, as a
    fraction of ankle -> toe base."""
    for s in ("left", "right"):
        J[s + "_hand"] = J[s + "_wrist"] + 0.17 * g * (J[s + "_wrist"] - J[s + "_elbow"]) / \
            max(1e-6, np.linalg.norm(J[s + "_wrist"] - J[s + "_elbow"]))
        J[s + "_toetip"] = J[s + "_toe"] + toe_reach * (J[s + "_toe"] - J[s + "_ankle"])


# Data version 3 (issue 36; docs/DETECTOR_EXPERIMENTS.md, "Labels against
# the evaluation's joints"): the dev clips' mannequin has small feet the
# colour of its trousers and narrow shoulders, where the v2 renders' feet
# were one size in shoe colours; the detector put those ankles 3-4 px past
# the leg's end.  Ranges, drawn per actor:
V3_TOE_REACH = (0.1, 0.6)         # foot past the toe base (v2: 0.35)
V3_FOOT_GIRTH = (0.7, 1.35)       # foot radius factor (v2: build and garment only)
V3_SHOULDER_GIRTH = (0.7, 1.3)    # shoulder bar radius factor
V3_SHOES_AS_TROUSERS = 0.35       # the shoes take the trousers' (or legs') material


def _v3_shapes(fac, rng):
    """Version 3's feet and shoulders on top of fac (radius factors)."""
    foot = rng.uniform(*V3_FOOT_GIRTH)
    for n in ("l_foot", "r_foot"):
        fac[n] *= foot * rng.uniform(0.95, 1.05)
    fac["shoulders"] *= rng.uniform(*V3_SHOULDER_GIRTH)


def _dress(self, mats, garment, sleeve, longpants, rng):
    set_material(mats["shirt"], rng)
    skin = skin_colour(rng)
    set_material(mats["skin"], rng, base=skin, pattern="solid")
    self._copy(mats["shirt"] if sleeve == "long" else mats["skin"], mats["sleeve"])
    if "uarm" in mats:
        self._copy(mats["shirt"] if sleeve in ("long", "elbow") else mats["skin"], mats["uarm"])
        self._copy(mats["shirt"] if sleeve != "none" else mats["skin"], mats["shoulderwear"])
    set_material(mats["trousers"], rng)
    self._copy(mats["trousers"] if longpants else mats["skin"], mats["legwear"])
    set_material(mats["shoes"], rng, pattern=rng.choice(["solid", "noise"]))


def setup_v2(self, pose, rng, look, bypose=None, env=None):
    """The v2 frame: the wearer with look["build"] and look["garment"], the
    scene look["scene"], and the bystander posed by bypose (None: none).
    Returns the wearer's joints (labels are the wearer's only).

    env (tools/synth/clip.py's sequences): the room, its furniture, lamps and
    clutter and the bystander's place are set around the wearer's whole path
    instead of this frame's pelvis: {"centre": (x, y) of the path, "half":
    (x, y) half extents, "facing": the first frame's forward, and optionally
    "room_half": the half extents the room must hold (outside-in: the
    cameras too)}.  With the same rng state every frame, every frame then
    gets the same scene.  Without it the draws and the scene are as they
    always were."""
    H = pose["height"]
    J = {k: np.asarray(v, dtype=float) for k, v in pose["joints"].items()}
    if env is None:
        cx, cy, hx, hy, facing = J["pelvis"][0], J["pelvis"][1], 0.0, 0.0, pose["head"][:, 0]
    else:
        (cx, cy), (hx, hy), facing = env["centre"], env["half"], np.asarray(env["facing"], dtype=float)
    reach = max(hx, hy)
    g = H / 1.75
    v3 = look.get("version", 2) >= 3  # v2's random draws stay as they were
    _extremities(J, g, rng.uniform(*V3_TOE_REACH) if v3 else 0.35)
    bf, depth = build_girth(look["build"], rng)
    gf, sleeve, longpants = garment_cut(look["garment"], rng)
    fac = {n: bf[n] * gf[n] * rng.uniform(0.92, 1.08) for n, *_ in SEGMENTS}
    if v3:
        _v3_shapes(fac, rng)
    # the wearer's own head: outside-in only (no draw: the v2 data are ego)
    _place_body(self.seg, J, g, fac, depth, self.head, 0.085 * g)
    _dress(self, self.mats, look["garment"], sleeve, longpants, rng)
    if v3 and rng.random() < V3_SHOES_AS_TROUSERS:
        self._copy(self.mats["legwear"], self.mats["shoes"])
    look["longpants"] = bool(longpants)
    # bystander
    on = bypose is not None
    for ob in self.by_seg.values():
        self._show(ob, on)
    if on:
        Hb = bypose["height"]
        Jb = {k: np.asarray(v, dtype=float) for k, v in bypose["joints"].items()}
        gb = Hb / 1.75
        _extremities(Jb, gb)
        F = facing.copy()
        F[2] = 0.0
        a_f = math.atan2(F[1], F[0]) if np.linalg.norm(F) > 1e-6 else 0.0
        az = a_f + (rng.uniform(-1.75, 1.75) if rng.random() < 0.8 else rng.uniform(-math.pi, math.pi))
        dist = rng.uniform(*BYSTANDER_DIST)
        yaw = rng.uniform(-math.pi, math.pi)
        c, s = math.cos(yaw), math.sin(yaw)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        off = np.array([cx + (dist + reach) * math.cos(az), cy + (dist + reach) * math.sin(az), 0.0])
        Jb = {k: Rz @ v + off for k, v in Jb.items()}
        bb = rng.choice(BUILDS[look["split"]])
        bgar = rng.choice(GARMENTS[look["split"]])
        bbf, bdepth = build_girth(bb, rng)
        bgf, bsl, blp = garment_cut(bgar, rng)
        bfac = {n: bbf[n] * bgf[n] for n, *_ in SEGMENTS}
        _place_body(self.by_seg, Jb, gb, bfac, bdepth, self.by_seg["head"], 0.085 * gb * rng.uniform(0.92, 1.08))
        _dress(self, self.by_mats, bgar, bsl, blp, rng)
        look["bystander_m"] = round(float(dist), 3)
        look["bystander_clip"] = bypose["clip"]
        self._by_xy = off[:2]
    # environment
    kind = look["scene"]
    pale = rng.random() < 0.5
    set_material(self.floor_mat, rng, scale=rng.uniform(0.05, 1.0), smax=0.35 if pale else 1.0)
    self.floor.location = (0, 0, 0)
    self.floor.rotation_euler = (0, 0, rng.uniform(0, 6.3))
    indoor = kind != "outdoor"
    self._show(self.room, indoor)
    if kind == "hall":
        w, d, h = rng.uniform(5, 14), rng.uniform(5, 14), rng.uniform(2.8, 4.5)
    elif kind == "room":
        w, d, h = rng.uniform(3.0, 5.5), rng.uniform(3.0, 5.5), rng.uniform(2.3, 2.8)
    if indoor:
        # the wearer (and bystander) inside: the room's centre within reach
        ox = rng.uniform(-0.25, 0.25) * w
        oy = rng.uniform(-0.25, 0.25) * d
        if on:
            ox = 0.5 * (self._by_xy[0] + cx) + rng.uniform(-0.1, 0.1) * w
            oy = 0.5 * (self._by_xy[1] + cy) + rng.uniform(-0.1, 0.1) * d
            w = max(w, abs(self._by_xy[0] - cx) * 2 + 1.2 + 2 * hx)
            d = max(d, abs(self._by_xy[1] - cy) * 2 + 1.2 + 2 * hy)
        elif env is not None:
            ox, oy = cx + ox, cy + oy
        if env is not None:  # the whole path (and any cameras) inside, 0.8 m from the walls
            rhx, rhy = env.get("room_half", (hx, hy))
            w, d = max(w, 2 * (rhx + abs(ox - cx)) + 1.6), max(d, 2 * (rhy + abs(oy - cy)) + 1.6)
        self.room.scale = (w, d, h)
        self.room.location = (ox, oy, h / 2 - 0.01)
        set_material(self.wall_mat, rng, scale=rng.uniform(0.1, 1.0), smax=0.35 if pale or kind == "room" else 1.0)
    sky = np.array(random_colour(rng)) * 0.3 + np.array([0.5, 0.6, 0.8]) * rng.uniform(0.2, 0.8)
    self.bg.inputs[0].default_value = tuple(sky) + (1,)
    self.bg.inputs[1].default_value = rng.uniform(0.3, 1.5) if not indoor else (0.5 if kind == "hall" else 0.15)
    sun = self.sun.data
    self._show(self.sun, not indoor)
    sun.energy = rng.uniform(1.5, 6.0)
    sun.color = tuple(1 - rng.uniform(0, 0.25, 3))
    sun.angle = math.radians(rng.uniform(0.5, 10))
    el, az = rng.uniform(math.radians(20), math.radians(85)), rng.uniform(0, 6.283)
    dvec = -Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)))
    self.sun.rotation_euler = dvec.to_track_quat("-Z", "Y").to_euler()
    rl, rs = self.room.location, self.room.scale
    # hall: 1-3 lamps under the ceiling or on the walls
    for i, lp in enumerate(self.lamps):
        on_l = kind == "hall" and (i == 0 or rng.random() < 0.5)
        self._show(lp, on_l)
        if on_l:
            zl = rs[2] - 0.3 if rng.random() < 0.7 else rng.uniform(1.2, rs[2] - 0.3)
            lp.location = (rl[0] + rng.uniform(-0.4, 0.4) * rs[0], rl[1] + rng.uniform(-0.4, 0.4) * rs[1], zl)
            lp.data.energy = rng.uniform(300, 1500)
            lp.data.color = tuple(1 - rng.uniform(0, 0.3, 3))
            lp.data.shadow_soft_size = rng.uniform(0.05, 0.5)
    # room: furniture along the walls and 1-3 standing or table lamps, warm
    nf = int(rng.integers(3, len(self.furniture) + 1)) if kind == "room" else 0
    for i, (ob, m) in enumerate(self.furniture):
        self._show(ob, i < nf)
        if i >= nf:
            continue
        sx, sy, sz = rng.uniform(0.4, 2.0), rng.uniform(0.35, 0.9), rng.uniform(0.4, 2.0)
        wall = int(rng.integers(4))
        t = rng.uniform(-0.4, 0.4)
        # keep 0.55 m between the furniture and the wearer's pelvis
        gap = [rl[1] + rs[1] / 2 - cy - hy, cy - hy - (rl[1] - rs[1] / 2),
               rl[0] + rs[0] / 2 - cx - hx, cx - hx - (rl[0] - rs[0] / 2)][wall]
        sy = min(sy, gap - 0.55)
        if sy < 0.2:
            self._show(ob, False)
            continue
        if wall < 2:
            x = rl[0] + t * rs[0]
            y = rl[1] + (0.5 * rs[1] - sy / 2 - 0.02) * (1 if wall == 0 else -1)
            ob.scale = (sx, sy, sz)
        else:
            x = rl[0] + (0.5 * rs[0] - sy / 2 - 0.02) * (1 if wall == 2 else -1)
            y = rl[1] + t * rs[1]
            ob.scale = (sy, sx, sz)
        ob.location = (x, y, sz / 2)
        ob.rotation_euler = (0, 0, 0)
        set_material(m, rng, scale=rng.uniform(1, 6))
    nl = int(rng.integers(1, 4)) if kind == "room" else 0
    warm = np.array([1.0, 0.78, 0.55])
    for i, fx in enumerate(self.fixtures):
        onf = i < nl
        for k in ("pole", "shade", "light"):
            self._show(fx[k], onf)
        if not onf:
            continue
        ang = rng.uniform(0, 2 * math.pi)
        x = rl[0] + 0.5 * rs[0] * math.cos(ang) * rng.uniform(0.3, 0.85)
        y = rl[1] + 0.5 * rs[1] * math.sin(ang) * rng.uniform(0.3, 0.85)
        if np.hypot(x - cx, y - cy) < 0.7 + reach:
            x += 0.8 * math.cos(ang)
            y += 0.8 * math.sin(ang)
        top = rng.uniform(0.7, 1.8)
        fx["pole"].scale = (0.03, 0.03, top)
        fx["pole"].location = (x, y, top / 2)
        sr = rng.uniform(0.15, 0.3)
        fx["shade"].scale = (sr, sr, sr * 1.1)
        fx["shade"].location = (x, y, top + sr * 0.4)
        col = tuple(float(c) for c in warm * (1 - rng.uniform(0, 0.15, 3)))
        fx["em"].inputs[0].default_value = col + (1,)
        fx["em"].inputs[1].default_value = rng.uniform(0.5, 2.0)
        fx["dif"].inputs[0].default_value = col + (1,)
        fx["light"].location = (x, y, top + sr * 0.3)
        fx["light"].data.energy = rng.uniform(200, 800)
        fx["light"].data.color = col
        fx["light"].data.shadow_soft_size = rng.uniform(0.1, 0.3)
        set_material(fx["polemat"], rng)
    if kind == "room":  # a ceiling light as well (dim or bright)
        lp = self.lamps[0]
        self._show(lp, True)
        lp.location = (rl[0] + rng.uniform(-0.2, 0.2) * rs[0], rl[1] + rng.uniform(-0.2, 0.2) * rs[1], rs[2] - 0.2)
        lp.data.energy = rng.uniform(100, 600)
        lp.data.color = tuple(float(c) for c in warm * (1 - rng.uniform(0, 0.15, 3)))
        lp.data.shadow_soft_size = rng.uniform(0.1, 0.4)
    # clutter: outdoors and in halls as before, in rooms a few small things
    n = int(rng.integers(0, N_CLUTTER + 1)) if kind != "room" else int(rng.integers(0, 5))
    for i, (ob, m, ck) in enumerate(self.clutter):
        on_c = i < n
        self._show(ob, on_c)
        if not on_c:
            continue
        rr = rng.uniform(0.7, 4.5) if kind != "room" else rng.uniform(0.7, 1.8)
        a = rng.uniform(0, 6.283)
        sz = rng.uniform(0.08, 0.6, 3)
        if ck == 2:
            sz[:] = sz[0]
        ob.scale = tuple(sz)
        ob.location = (cx + (rr + reach) * math.cos(a), cy + (rr + reach) * math.sin(a), sz[2] / 2)
        ob.rotation_euler = (0, 0, rng.uniform(0, 6.3))
        set_material(m, rng)
    bpy.context.view_layer.update()
    self.sc.view_settings.view_transform = "Filmic" if rng.random() < 0.5 else "Standard"
    self.sc.view_settings.exposure = rng.uniform(-0.7, 0.7) + (0.3 if kind == "room" else 0.0)
    return J


Scene.init_v2 = init_v2
Scene.setup_v2 = setup_v2
