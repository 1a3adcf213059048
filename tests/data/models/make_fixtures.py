#!/usr/bin/env python3
"""Writes the bad-input model fixtures used by tests/test_model_io.c.

Each file breaks one rule of docs/MODEL_FORMAT.md; the test checks that
loading it fails with an error naming the file and the field.  Run from this
folder: python3 make_fixtures.py"""
import copy, json

BASE = {
    "name": "tiny",
    "root": "fixed",
    "joints": [
        {"name": "head", "offset": [0, 0, 0]},
        {"name": "neck", "parent": "head", "offset": [0, 0.1, 0],
         "dofs": [{"axis": "x", "min_deg": -45, "max_deg": 45}]},
        {"name": "spine", "parent": "neck", "offset": [0, 0.3, 0],
         "dofs": [{"axis": "x", "min_deg": -30, "max_deg": 90}, {"axis": "y", "min_deg": -45, "max_deg": 45}]},
        {"name": "pelvis", "parent": "spine", "offset": [0, 0.2, 0]},
        {"name": "left_hip", "parent": "pelvis", "offset": [-0.1, 0.1, 0],
         "dofs": [{"axis": "z", "min_deg": -30, "max_deg": 50}]},
    ],
    "gaussians": [
        {"joint": "head", "offset": [0, -0.03, 0], "radius": 0.1, "color": "#d8a788"},
        {"joint": "spine", "offset": [0, 0.1, 0], "radius": 0.09, "color": [0.3, 0.4, 0.6]},
    ],
}


def write(name, model):
    with open(name, "w") as f:
        json.dump(model, f, indent=1)
        f.write("\n")


def variant(name, edit):
    m = copy.deepcopy(BASE)
    edit(m)
    write(name, m)


write("good_tiny.json", BASE)
variant("missing_joints.json", lambda m: m.pop("joints"))
variant("missing_radius.json", lambda m: m["gaussians"][1].pop("radius"))
variant("missing_joint_name.json", lambda m: m["joints"][2].pop("name"))
variant("wrong_type_offset.json", lambda m: m["joints"][1].__setitem__("offset", "0 0.1 0"))
variant("wrong_type_radius.json", lambda m: m["gaussians"][0].__setitem__("radius", "big"))
variant("wrong_type_joints.json", lambda m: m.__setitem__("joints", {"head": {}}))
variant("short_offset.json", lambda m: m["gaussians"][1].__setitem__("offset", [0, 0.1]))
variant("radius_zero.json", lambda m: m["gaussians"][1].__setitem__("radius", 0))
variant("radius_negative.json", lambda m: m["gaussians"][0].__setitem__("radius", -0.05))
variant("unknown_parent.json", lambda m: m["joints"][3].__setitem__("parent", "chest"))
variant("unknown_gauss_joint.json", lambda m: m["gaussians"][1].__setitem__("joint", "hand"))
variant("unknown_bone.json", lambda m: m["gaussians"][0].__setitem__("bone", "skull"))


def cycle(m):
    # neck -> pelvis -> spine -> neck, detached from the root
    m["joints"][1]["parent"] = "pelvis"
variant("cycle.json", cycle)
variant("self_parent.json", lambda m: m["joints"][4].__setitem__("parent", "left_hip"))


def parent_after_child(m):
    j = m["joints"]
    j[2], j[3] = j[3], j[2]  # pelvis listed before its parent spine
variant("parent_after_child.json", parent_after_child)
variant("two_roots.json", lambda m: m["joints"][3].pop("parent"))
variant("duplicate_name.json", lambda m: m["joints"][4].__setitem__("name", "spine"))
variant("empty_name.json", lambda m: m["joints"][4].__setitem__("name", ""))
# issue 34: a name that breaks out of the JSON export's string
variant("name_quote.json", lambda m: m["joints"][4].__setitem__("name", 'x"},\n{"evil'))
variant("unknown_axis.json", lambda m: m["joints"][2]["dofs"][1].__setitem__("axis", "w"))
variant("repeated_axis.json", lambda m: m["joints"][2]["dofs"][1].__setitem__("axis", "x"))
variant("min_gt_max.json", lambda m: m["joints"][1]["dofs"][0].update({"min_deg": 30, "max_deg": 10}))
variant("missing_limit.json", lambda m: m["joints"][1]["dofs"][0].pop("max_deg"))
variant("four_dofs.json", lambda m: m["joints"][2].__setitem__(
    "dofs", [{"axis": a, "min_deg": -10, "max_deg": 10} for a in "xyzx"]))
variant("bad_hex_color.json", lambda m: m["gaussians"][0].__setitem__("color", "#d8a7zz"))
variant("color_range.json", lambda m: m["gaussians"][1].__setitem__("color", [0.3, 1.5, 0.6]))
variant("unknown_field.json", lambda m: m["gaussians"][1].__setitem__("raduis", 0.1))
variant("bad_root_kind.json", lambda m: m.__setitem__("root", "floating"))
variant("free_with_rig_from_root.json", lambda m: m.update(
    {"root": "free", "rig_from_root": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}))
variant("rig_from_root_scaled.json", lambda m: m.__setitem__(
    "rig_from_root", [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]]))
variant("smoothness_range.json", lambda m: m.__setitem__("smoothness_m", 1.5))
variant("bone_scale_zero.json", lambda m: m["joints"][2].__setitem__("bone_scale", 0))
variant("offset_huge.json", lambda m: m["joints"][2].__setitem__("offset", [0, 1e6, 0]))
variant("note_not_string.json", lambda m: m.__setitem__("note", ["not", "text"]))
variant("empty_joints.json", lambda m: m.__setitem__("joints", []))


def too_many_joints(m):
    m["joints"] = [{"name": "j0", "offset": [0, 0, 0]}] + [
        {"name": "j%d" % i, "parent": "j%d" % (i - 1), "offset": [0, 0.01, 0]} for i in range(1, 33)]
    m["gaussians"] = [{"joint": "j0", "offset": [0, 0, 0], "radius": 0.1, "color": "#ffffff"}]
variant("too_many_joints.json", too_many_joints)


def too_many_dofs(m):
    # 32 joints x 3 dofs + 6 free-root dofs = 102 > 96
    m["root"] = "free"
    dofs = [{"axis": a, "min_deg": -10, "max_deg": 10} for a in "xyz"]
    m["joints"] = [{"name": "j0", "offset": [0, 0, 0], "dofs": dofs}] + [
        {"name": "j%d" % i, "parent": "j%d" % (i - 1), "offset": [0, 0.01, 0], "dofs": dofs} for i in range(1, 32)]
    m["gaussians"] = [{"joint": "j0", "offset": [0, 0, 0], "radius": 0.1, "color": "#ffffff"}]
variant("too_many_dofs.json", too_many_dofs)
variant("too_many_gaussians.json", lambda m: m.__setitem__(
    "gaussians", [{"joint": "spine", "offset": [0, 0.001 * i, 0], "radius": 0.05, "color": "#808080"}
                  for i in range(129)]))

# Literals JSON itself forbids: jansson refuses them at parse time.
text = json.dumps(BASE, indent=1)
with open("nan_number.json", "w") as f:
    f.write(text.replace('"radius": 0.09', '"radius": NaN') + "\n")
with open("inf_number.json", "w") as f:
    f.write(text.replace('"radius": 0.09', '"radius": 1e999') + "\n")
with open("top_level_array.json", "w") as f:
    f.write("[1, 2, 3]\n")
