# SPDX-License-Identifier: MIT
"""Examples/csgv_tools.py's hide_label, show_only_label and select_labels against the cases in
material_label_edits.json, which Core's csgv::hideLabel, csgv::showOnlyLabel and csgv::editSelection pass in
Testing/Core/test_materials.cpp (Materials.LabelEditsMatchTheSharedCases): pvpython cannot call
Core, so the shared cases keep the two implementations from drifting apart."""
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "Examples"))
import csgv_tools as ct  # noqa: E402

MAX_LABEL = 4294967294.0


def normalised(doc):
    """A document with MATERIALS.md's defaults filled in and numbers as floats (Core writes every
    key; the Python helpers write what they were given)."""
    def num(v):
        return [num(x) for x in v] if isinstance(v, list) else float(v)
    out = []
    for m in doc.get("materials", []):
        f = dict({"attribute": "label", "min": 1, "max": MAX_LABEL}, **m.get("filter", {}))
        c = dict(m.get("color", {"mode": "random"}))
        if c.get("mode", "random") == "colormap":
            c = dict({"attribute": "label", "min": 0, "max": 1, "wrap": "clamp"}, **c)
        c.setdefault("mode", "random")
        c = {k: (v if isinstance(v, str) else num(v)) for k, v in c.items()}
        out.append({"name": m.get("name", ""),
                    "filter": {"attribute": f["attribute"], "min": num(f["min"]), "max": num(f["max"])},
                    "color": c, "opacity": num(m.get("opacity", 1)), "emission": num(m.get("emission", 0))})
    return {"version": int(doc.get("version", 1)), "materials": out,
            "hidden": sorted(int(x) for x in doc.get("hidden", [])), "only": sorted(int(x) for x in doc.get("only", [])),
            "selected": sorted(int(x) for x in doc.get("selected", [])),
            "selectionStyle": doc.get("selectionStyle", "highlight"),
            "selectionColor": num(doc.get("selectionColor", [1, 0, 1]))}


failures = 0
with open(os.path.join(HERE, "material_label_edits.json")) as f:
    cases = json.load(f)["cases"]
assert len(cases) >= 10, "the shared cases are missing"
for case in cases:
    text = case["input"] if isinstance(case["input"], str) else json.dumps(case["input"])
    attrs = case.get("attributes", {})
    if case["op"] == "select":
        got = normalised(json.loads(ct.select_labels(text, case["labels"], case["edit"], case.get("style"))))
    else:
        fn = {"hide": ct.hide_label, "showOnly": ct.show_only_label}[case["op"]]
        got = normalised(json.loads(fn(text, case["label"], lambda name: attrs.get(name))))
    want = normalised(case["expected"])
    ok = got == want
    failures += not ok
    print("%s: %s" % ("ok" if ok else "FAIL", case["what"]))
    if not ok:
        print("  got:      %s\n  expected: %s" % (json.dumps(got), json.dumps(want)))

# The default document is Core's defaultMaterials() (one material "all", every non-zero label).
default = normalised(ct.DEFAULT_DOCUMENT)
want = normalised({"version": 1, "materials": [{"name": "all", "filter": {"attribute": "label", "min": 1.0, "max": MAX_LABEL},
                                                "color": {"mode": "random"}, "opacity": 1.0, "emission": 0.0}]})
if default != want:
    failures += 1
    print("FAIL: DEFAULT_DOCUMENT is not Core's default document: %s" % json.dumps(default))
print("%d of %d cases failed" % (failures, len(cases) + 1))
sys.exit(1 if failures else 0)
