"""The Blender scene of the detector's data generator (tools/synth/render.py):
the mannequin (SEGMENTS, and ADJ for what may hide a joint), its random
clothes, the room, clutter and lights (Scene), rendering one view, and the
marker spheres of --test-projection.  Runs inside Blender only (bpy).
"""
import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

# mannequin segments: name, joint a, joint b, radius (fraction of 1.75 m actor), material
SEGMENTS = [
    ("hips", "left_hip", "right_hip", 0.135, "trousers"),
    ("abdomen", "pelvis", "spine", 0.165, "shirt"),
    ("chest", "spine", "neck", 0.185, "shirt"),
    ("shoulders", "left_shoulder", "right_shoulder", 0.075, "shirt"),
    ("l_uarm", "left_shoulder", "left_elbow", 0.060, "shirt"),
    ("r_uarm", "right_shoulder", "right_elbow", 0.060, "shirt"),
    ("l_farm", "left_elbow", "left_wrist", 0.048, "sleeve"),
    ("r_farm", "right_elbow", "right_wrist", 0.048, "sleeve"),
    ("l_hand", "left_wrist", "left_hand", 0.038, "skin"),
    ("r_hand", "right_wrist", "right_hand", 0.038, "skin"),
    ("l_thigh", "left_hip", "left_knee", 0.092, "trousers"),
    ("r_thigh", "right_hip", "right_knee", 0.092, "trousers"),
    ("l_shin", "left_knee", "left_ankle", 0.065, "legwear"),
    ("r_shin", "right_knee", "right_ankle", 0.065, "legwear"),
    ("l_foot", "left_ankle", "left_toetip", 0.045, "shoes"),
    ("r_foot", "right_ankle", "right_toetip", 0.045, "shoes"),
]
# which segments may hide a joint without counting as "occluded" (its own limb)
ADJ = {
    "head_top": [], "neck": ["chest"], "spine": ["abdomen", "chest"], "pelvis": ["abdomen", "hips"],
}
for s in ("left", "right"):
    p = s[0]
    ADJ.update({
        s + "_shoulder": [p + "_uarm", "shoulders", "chest"], s + "_elbow": [p + "_uarm", p + "_farm"],
        s + "_wrist": [p + "_farm", p + "_hand"], s + "_hip": ["hips", p + "_thigh", "abdomen"],
        s + "_knee": [p + "_thigh", p + "_shin"], s + "_ankle": [p + "_shin", p + "_foot"],
        s + "_toe": [p + "_foot"],
    })
# the outside-in actor's own head (there is no "head" object in the ego scenes)
ADJ["head_top"] = ADJ["head_top"] + ["head"]
ADJ["neck"] = ADJ["neck"] + ["head"]
N_CLUTTER = 16


def blender_cam_matrix(T_world_cv):
    """OpenCV camera pose (4x4, world from cam) -> Blender camera matrix_world."""
    M = T_world_cv.copy()
    M[:3, 1] *= -1.0
    M[:3, 2] *= -1.0
    return Matrix(M.tolist())


def segment_matrix(J, name, a, b, Lax, rad, depth=1.0):
    """The ellipsoid of segment `name` from joint a to b (J), radius rad, its
    x axis across the shoulders (Lax); depth scales the trunk's front-back
    radius.  Returns the 4x4 world matrix and the segment's unit axis (for
    a caller that moves the centre: v2's belly)."""
    pa, pb = J[a], J[b]
    if name == "chest":
        pb = pa + 0.88 * (pb - pa)
    d = pb - pa
    ln = max(np.linalg.norm(d), 1e-4)
    z = d / ln
    x = Lax - np.dot(Lax, z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.3, 0.2, 0.9])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    half = 0.5 * ln * (1.12 if name not in ("hips", "shoulders") else 1.0) + \
        (rad * 0.7 if name in ("hips", "shoulders") else 0.0)
    rx, ry = rad, rad
    if name in ("abdomen", "chest"):
        rx, ry = rad * 1.1, rad * 0.75 * depth
    if name == "hips":
        rx, ry = rad, rad * 1.1
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2] = x * rx, y * ry, z * max(half, rad * 0.9)
    M[:3, 3] = 0.5 * (pa + pb)
    return M, z


def make_material(name, kind="pattern"):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(bsdf.outputs[0], out.inputs[0])
    tc = nt.nodes.new("ShaderNodeTexCoord")
    mapn = nt.nodes.new("ShaderNodeMapping")
    nt.links.new(tc.outputs["Object"], mapn.inputs["Vector"])
    wave = nt.nodes.new("ShaderNodeTexWave")
    chk = nt.nodes.new("ShaderNodeTexChecker")
    noise = nt.nodes.new("ShaderNodeTexNoise")
    for t in (wave, chk, noise):
        nt.links.new(mapn.outputs[0], t.inputs["Vector"])
    chk.inputs["Color1"].default_value = (1, 1, 1, 1)
    chk.inputs["Color2"].default_value = (0, 0, 0, 1)
    # fac = w0*wave + w1*checker + w2*noise
    m0 = nt.nodes.new("ShaderNodeMath"); m0.operation = "MULTIPLY"
    m1 = nt.nodes.new("ShaderNodeMath"); m1.operation = "MULTIPLY"
    m2 = nt.nodes.new("ShaderNodeMath"); m2.operation = "MULTIPLY"
    nt.links.new(wave.outputs["Fac"], m0.inputs[0])
    nt.links.new(chk.outputs["Fac"], m1.inputs[0])
    nt.links.new(noise.outputs["Fac"], m2.inputs[0])
    a0 = nt.nodes.new("ShaderNodeMath"); a0.operation = "ADD"
    a1 = nt.nodes.new("ShaderNodeMath"); a1.operation = "ADD"; a1.use_clamp = True
    nt.links.new(m0.outputs[0], a0.inputs[0]); nt.links.new(m1.outputs[0], a0.inputs[1])
    nt.links.new(a0.outputs[0], a1.inputs[0]); nt.links.new(m2.outputs[0], a1.inputs[1])
    mix = nt.nodes.new("ShaderNodeMixRGB")
    nt.links.new(a1.outputs[0], mix.inputs["Fac"])
    nt.links.new(mix.outputs[0], bsdf.inputs["Color"])
    m["nodes"] = 1
    return m


def set_material(m, rng, base=None, pattern=None, scale=None, smax=1.0):
    nt = m.node_tree
    nd = {n.bl_idname + str(i): n for i, n in enumerate(nt.nodes)}
    nodes = list(nt.nodes)
    mapn = [n for n in nodes if n.bl_idname == "ShaderNodeMapping"][0]
    wave = [n for n in nodes if n.bl_idname == "ShaderNodeTexWave"][0]
    chk = [n for n in nodes if n.bl_idname == "ShaderNodeTexChecker"][0]
    noise = [n for n in nodes if n.bl_idname == "ShaderNodeTexNoise"][0]
    mults = [n for n in nodes if n.bl_idname == "ShaderNodeMath" and n.operation == "MULTIPLY"]
    mix = [n for n in nodes if n.bl_idname == "ShaderNodeMixRGB"][0]
    bsdf = [n for n in nodes if n.bl_idname == "ShaderNodeBsdfDiffuse"][0]
    del nd
    c1 = random_colour(rng, smax) if base is None else base
    c2 = random_colour(rng, smax)
    if pattern is None:
        pattern = rng.choice(["solid", "stripes", "checks", "noise"], p=[0.4, 0.2, 0.2, 0.2])
    w = {"solid": (0, 0, 0), "stripes": (1, 0, 0), "checks": (0, 1, 0), "noise": (0, 0, 1)}[pattern]
    for k in range(3):
        mults[k].inputs[1].default_value = w[k]
    sc = rng.uniform(2.0, 12.0) if scale is None else scale
    mapn.inputs["Scale"].default_value = (sc, sc, sc)
    mapn.inputs["Rotation"].default_value = tuple(rng.uniform(0, 6.28, 3))
    wave.inputs["Scale"].default_value = rng.uniform(0.5, 2.0)
    wave.inputs["Distortion"].default_value = rng.uniform(0, 2)
    chk.inputs["Scale"].default_value = rng.uniform(0.5, 2.0)
    noise.inputs["Scale"].default_value = rng.uniform(0.3, 3.0)
    noise.inputs["Detail"].default_value = rng.uniform(0, 6)
    mix.inputs["Color1"].default_value = tuple(c1) + (1,)
    mix.inputs["Color2"].default_value = tuple(c2) + (1,)
    bsdf.inputs["Roughness"].default_value = rng.uniform(0, 1)


def random_colour(rng, smax=1.0):
    h, s, v = rng.uniform(0, 1), smax * rng.uniform(0, 1) ** 0.7, rng.uniform(0.05, 0.9)
    i = int(h * 6) % 6
    f = h * 6 - int(h * 6)
    p, q, t = v * (1 - s), v * (1 - f * s), v * (1 - (1 - f) * s)
    rgb = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i]
    return tuple(float(c) ** 2.2 for c in rgb)  # linear


def skin_colour(rng):
    base = np.array([0.95, 0.75, 0.6]) * rng.uniform(0.25, 1.0)
    base = base * (1 + rng.uniform(-0.08, 0.08, 3))
    return tuple(float(np.clip(c, 0, 1)) ** 2.2 for c in base)


class Scene:
    def __init__(self, args, cams):
        self.args = args
        self.cams = cams
        bpy.ops.wm.read_factory_settings(use_empty=True)
        sc = bpy.context.scene
        self.sc = sc
        sc.render.engine = "CYCLES"
        cy = sc.cycles
        cy.device = "CPU"
        cy.samples = args.samples
        cy.use_denoising = False
        cy.use_adaptive_sampling = False
        cy.max_bounces = 2
        cy.diffuse_bounces = 1
        cy.glossy_bounces = 0
        cy.transmission_bounces = 0
        cy.volume_bounces = 0
        cy.transparent_max_bounces = 0
        cy.caustics_reflective = False
        cy.caustics_refractive = False
        try:
            cy.use_auto_tile = False
        except AttributeError:
            pass
        sc.render.threads_mode = "FIXED"
        sc.render.threads = args.threads
        sc.render.resolution_x = args.res_w
        sc.render.resolution_y = args.res_h
        sc.render.resolution_percentage = 100
        sc.render.use_persistent_data = True
        sc.render.image_settings.file_format = "PNG"
        sc.render.image_settings.color_mode = "RGB"
        sc.render.film_transparent = False
        world = bpy.data.worlds.new("W")
        world.use_nodes = True
        sc.world = world
        self.bg = world.node_tree.nodes["Background"]
        # camera
        cd = bpy.data.cameras.new("cam")
        cd.type = "PANO" if args.kind == "ego" else "PERSP"
        for tgt in ((cd, getattr(cd, "cycles", None)) if args.kind == "ego" else ()):
            if tgt is None:
                continue
            try:
                tgt.panorama_type = "FISHEYE_EQUIDISTANT"
                tgt.fisheye_fov = math.pi
            except (AttributeError, TypeError):
                pass
        cd.clip_start = 0.01
        cd.clip_end = 100
        cd.sensor_fit = "HORIZONTAL"
        self.cam = bpy.data.objects.new("cam", cd)
        sc.collection.objects.link(self.cam)
        sc.camera = self.cam
        # mannequin
        self.mats = {k: make_material(k) for k in ("shirt", "sleeve", "trousers", "legwear", "skin", "shoes")}
        bpy.ops.mesh.primitive_uv_sphere_add(segments=20, ring_count=10, radius=1.0)
        self.sphere = bpy.context.active_object.data
        bpy.ops.object.shade_smooth()
        bpy.data.objects.remove(bpy.context.active_object)
        self.seg = {}
        for name, a, b, r, mat in SEGMENTS:
            me = self.sphere.copy()
            me.materials.append(self.mats[mat])
            ob = bpy.data.objects.new(name, me)
            sc.collection.objects.link(ob)
            self.seg[name] = ob
        self.head = None
        if args.kind == "outside":  # the actor's own head (the ego wearer's is never seen)
            me = self.sphere.copy()
            me.materials.append(self.mats["skin"])
            self.head = bpy.data.objects.new("head", me)
            sc.collection.objects.link(self.head)
            self.seg["head"] = self.head
        self.body = set(self.seg.values())
        # floor, room, clutter
        self.floor_mat = make_material("floor")
        bpy.ops.mesh.primitive_plane_add(size=60)
        self.floor = bpy.context.active_object
        self.floor.data.materials.append(self.floor_mat)
        self.wall_mat = make_material("wall")
        bpy.ops.mesh.primitive_cube_add(size=1)
        self.room = bpy.context.active_object
        self.room.data.materials.append(self.wall_mat)
        self.clutter = []
        for i in range(N_CLUTTER):
            kind = i % 3
            if kind == 0:
                bpy.ops.mesh.primitive_cube_add(size=1)
            elif kind == 1:
                bpy.ops.mesh.primitive_cylinder_add(vertices=16, radius=0.5, depth=1)
            else:
                bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=0.5)
            ob = bpy.context.active_object
            m = make_material("clutter%d" % i)
            ob.data.materials.append(m)
            self.clutter.append((ob, m, kind))
        # lights
        sd = bpy.data.lights.new("sun", "SUN")
        self.sun = bpy.data.objects.new("sun", sd)
        sc.collection.objects.link(self.sun)
        self.lamps = []
        for i in range(2):
            ld = bpy.data.lights.new("lamp%d" % i, "POINT")
            ob = bpy.data.objects.new("lamp%d" % i, ld)
            sc.collection.objects.link(ob)
            self.lamps.append(ob)

    @staticmethod
    def _show(ob, on):
        ob.hide_render = not on
        ob.hide_viewport = not on

    def setup(self, pose, rng, cams=None):
        """cams (outside-in only): the views' world-from-camera poses; an
        indoor room is then made large enough to hold them."""
        H = pose["height"]
        J = {k: np.asarray(v, dtype=float) for k, v in pose["joints"].items()}
        g = H / 1.75
        girth = rng.uniform(0.8, 1.25)
        for s in ("left", "right"):
            J[s + "_hand"] = J[s + "_wrist"] + 0.45 * (J[s + "_wrist"] - J[s + "_elbow"]) * \
                (0.17 * g / max(1e-6, np.linalg.norm(J[s + "_wrist"] - J[s + "_elbow"])) / 0.45)
            J[s + "_toetip"] = J[s + "_toe"] + 0.35 * (J[s + "_toe"] - J[s + "_ankle"])
        Lax = J["left_shoulder"] - J["right_shoulder"]
        for name, a, b, r, mat in SEGMENTS:
            rad = r * g * girth * rng.uniform(0.92, 1.08)
            M, _ = segment_matrix(J, name, a, b, Lax, rad)
            self.seg[name].matrix_world = Matrix(M.tolist())
        if self.head is not None:
            # skull: from the head joint (base of the skull) up past head_top
            up = J["head_top"] - J["neck"]
            upn = up / max(np.linalg.norm(up), 1e-6)
            fwd = np.cross(upn, Lax)
            fwd = fwd / max(np.linalg.norm(fwd), 1e-6)
            x = np.cross(fwd, upn)
            hr = 0.085 * g * rng.uniform(0.92, 1.08)
            M = np.eye(4)
            M[:3, 0], M[:3, 1], M[:3, 2] = x * hr * 0.95, fwd * hr * 1.1, upn * hr * 1.25
            M[:3, 3] = J["neck"] + 0.55 * up + 0.02 * g * fwd
            self.head.matrix_world = Matrix(M.tolist())
        # clothes
        sleeves = rng.random() < 0.6
        longpants = rng.random() < 0.75
        set_material(self.mats["shirt"], rng)
        skin = skin_colour(rng)
        set_material(self.mats["skin"], rng, base=skin, pattern="solid")
        if sleeves:
            self._copy(self.mats["shirt"], self.mats["sleeve"])
        else:
            self._copy(self.mats["skin"], self.mats["sleeve"])
        set_material(self.mats["trousers"], rng)
        self._copy(self.mats["trousers"] if longpants else self.mats["skin"], self.mats["legwear"])
        set_material(self.mats["shoes"], rng, pattern=rng.choice(["solid", "noise"]))
        # environment
        pale = rng.random() < 0.5
        set_material(self.floor_mat, rng, scale=rng.uniform(0.05, 1.0), smax=0.35 if pale else 1.0)
        self.floor.location = (0, 0, 0)
        self.floor.rotation_euler = (0, 0, rng.uniform(0, 6.3))
        indoor = rng.random() < 0.4
        self._show(self.room, indoor)
        if indoor and cams is not None:
            # outside-in: a room (hall) that holds every camera
            ox, oy = rng.uniform(-1, 1), rng.uniform(-1, 1)
            cx = max(abs(T[0, 3] - ox) for T in cams)
            cyy = max(abs(T[1, 3] - oy) for T in cams)
            cz = max(T[2, 3] for T in cams)
            w, d = 2 * cx + rng.uniform(0.6, 6), 2 * cyy + rng.uniform(0.6, 6)
            h = max(rng.uniform(2.5, 4.5), cz + rng.uniform(0.3, 1.5))
            self.room.scale = (w, d, h)
            self.room.location = (ox, oy, h / 2 - 0.01)
            set_material(self.wall_mat, rng, scale=rng.uniform(0.1, 1.0), smax=0.35 if pale else 1.0)
        elif indoor:
            w, d, h = rng.uniform(4, 12), rng.uniform(4, 12), rng.uniform(2.5, 4)
            self.room.scale = (w, d, h)
            self.room.location = (rng.uniform(-1, 1), rng.uniform(-1, 1), h / 2 - 0.01)
            set_material(self.wall_mat, rng, scale=rng.uniform(0.1, 1.0), smax=0.35 if pale else 1.0)
        sky = np.array(random_colour(rng)) * 0.3 + np.array([0.5, 0.6, 0.8]) * rng.uniform(0.2, 0.8)
        self.bg.inputs[0].default_value = tuple(sky) + (1,)
        self.bg.inputs[1].default_value = rng.uniform(0.3, 1.5) if not indoor else 0.5
        sun = self.sun.data
        self._show(self.sun, not indoor)
        sun.energy = rng.uniform(1.5, 6.0)
        sun.color = tuple(1 - rng.uniform(0, 0.25, 3))
        sun.angle = math.radians(rng.uniform(0.5, 10))
        el, az = rng.uniform(math.radians(20), math.radians(85)), rng.uniform(0, 6.283)
        dvec = -Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)))
        self.sun.rotation_euler = dvec.to_track_quat("-Z", "Y").to_euler()
        for i, lp in enumerate(self.lamps):
            on = indoor and (i == 0 or rng.random() < 0.5)
            self._show(lp, on)
            if on:
                if cams is None:
                    lp.location = (rng.uniform(-2, 2), rng.uniform(-2, 2), self.room.scale[2] - 0.3)
                else:
                    rl = self.room.location
                    lp.location = (rl[0] + rng.uniform(-0.35, 0.35) * self.room.scale[0],
                                   rl[1] + rng.uniform(-0.35, 0.35) * self.room.scale[1], self.room.scale[2] - 0.3)
                lp.data.energy = rng.uniform(300, 1500)
                lp.data.color = tuple(1 - rng.uniform(0, 0.3, 3))
                lp.data.shadow_soft_size = rng.uniform(0.05, 0.5)
        n = rng.integers(0, N_CLUTTER + 1)
        for i, (ob, m, kind) in enumerate(self.clutter):
            on = i < n
            self._show(ob, on)
            if not on:
                continue
            rr = rng.uniform(0.7, 4.5)
            a = rng.uniform(0, 6.283)
            sz = rng.uniform(0.08, 0.6, 3)
            if kind == 2:
                sz[:] = sz[0]
            ob.scale = tuple(sz)
            ob.location = (rr * math.cos(a), rr * math.sin(a), sz[2] / 2)
            ob.rotation_euler = (0, 0, rng.uniform(0, 6.3))
            set_material(m, rng)
        bpy.context.view_layer.update()
        # colour management / exposure
        self.sc.view_settings.view_transform = "Filmic" if rng.random() < 0.5 else "Standard"
        self.sc.view_settings.exposure = rng.uniform(-0.7, 0.7)
        return J

    @staticmethod
    def _copy(src, dst):
        sn = {i: n for i, n in enumerate(src.node_tree.nodes)}
        dn = {i: n for i, n in enumerate(dst.node_tree.nodes)}
        for i, s in sn.items():
            d = dn[i]
            for k, inp in enumerate(s.inputs):
                if hasattr(inp, "default_value"):
                    try:
                        d.inputs[k].default_value = inp.default_value
                    except (TypeError, AttributeError):
                        pass

    def occluded(self, origin, target, joint):
        dg = bpy.context.evaluated_depsgraph_get()
        d = target - origin
        dist = float(np.linalg.norm(d))
        hit, loc, nrm, idx, ob, mat = self.sc.ray_cast(dg, Vector(origin.tolist()), Vector((d / dist).tolist()),
                                                       distance=dist)
        if not hit:
            return False
        hd = (Vector(loc) - Vector(origin.tolist())).length
        if ob is not None and ob.name in ADJ.get(joint, []):
            return False
        if hd > dist - 0.03:
            return False
        return True

    def render_view(self, T_world_cv, path_png):
        self.cam.matrix_world = blender_cam_matrix(T_world_cv)
        self.sc.render.filepath = path_png
        bpy.ops.render.render(write_still=True)


def render_marker(sc, T, p, i, radius):
    """Renders a bright emissive sphere at camera-frame point p through the
    camera at rig pose T; returns the sphere and the centroid (u, v) of
    its bright pixels."""
    from PIL import Image
    m = make_material("em%d" % i)
    m.node_tree.nodes.clear()
    o = m.node_tree.nodes.new("ShaderNodeOutputMaterial")
    e = m.node_tree.nodes.new("ShaderNodeEmission")
    e.inputs[1].default_value = 50
    m.node_tree.links.new(e.outputs[0], o.inputs[0])
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius)
    ob = bpy.context.active_object
    ob.data.materials.append(m)
    ob.location = tuple(T[:3, :3] @ np.array(p) + T[:3, 3])
    sc.render_view(T, "/tmp/synth_proj.png")
    a = np.asarray(Image.open("/tmp/synth_proj.png").convert("L")).astype(float)
    ys, xs = np.nonzero(a > 128)
    w = a[ys, xs]
    return ob, (xs * w).sum() / w.sum(), (ys * w).sum() / w.sum()
