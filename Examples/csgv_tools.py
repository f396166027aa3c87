# SPDX-License-Identifier: MIT
"""pvpython helpers for the Segmentation Volume representation of the CSGV plugin: questions
answered where the volume renders (also on a pvserver), hiding and isolating labels in the
material document, and the materials' colours as a categorical lookup table.

    import sys; sys.path.append("<repository>/Examples")
    import csgv_tools
    d = Show(reader)                     # a Segmentation Volume display
    csgv_tools.attribute_summary(d)      # attribute names and ranges
    csgv_tools.pick(d, 100, 80)          # label, voxel, attributes under pixel (100, 80)
    d.CSGVMaterials = csgv_tools.hide_label(d.CSGVMaterials, 42)
    d.CSGVMaterials = csgv_tools.select_labels(d.CSGVMaterials, [3, 17], style="dim")
    csgv_tools.selected_labels(d.CSGVMaterials)       # [3, 17]: e.g. CSGVExtractLabels(Labels=...)
    csgv_tools.labels_in_rectangle(d, 0, 0, 99, 99)   # labels shown in a pixel rectangle
    csgv_tools.labels_matching(d, "voxels > 1000")    # labels whose attributes match (SQL)
    csgv_tools.apply_label_colors(d, slice_display)   # same colours and region names on a Slice

The questions go through the server-manager proxy misc/CSGVQuery (Representation/vtkCSGVQuery.h).
"""
import base64
import json

from paraview import servermanager as sm

# Core's kMaxMaterialLabel and defaultMaterials() (csgv/materials/Materials.h); pvpython cannot
# call Core, so test_material_label_edits.py checks these copies against the shared cases.
MAX_LABEL = 4294967294
DEFAULT_DOCUMENT = {"version": 1, "materials": [
    {"name": "all", "filter": {"attribute": "label", "min": 1, "max": MAX_LABEL},
     "color": {"mode": "random"}}]}


# pqCSGV::kBelowLabelsGrey and kLabelMargin (Plugin/CSGV/pqCSGVMaterialDocument.h).
BELOW_LABELS_GREY = 0.5
LABEL_MARGIN = 0.5


def _smproxy(display):
    return display.SMProxy if hasattr(display, "SMProxy") else display


def _drawn_on_client(proxy):
    """Client/server where the view renders on the client (a server that cannot render, such as
    Debian's pvserver without a display: ParaView moves the pieces to the client): the client's
    copy of the representation drew the volume, the server's nothing. The same rule as the GUI's
    (pqCSGV::query, Plugin/CSGV/pqCSGVMaterialDocument.cxx)."""
    if not proxy.GetSession().IsA("vtkSMSessionClient"):
        return False  # builtin, pvbatch: one process draws and answers (or every MPI rank)
    view = sm.vtkSMViewProxy.FindView(proxy)
    rendering = view.GetClientSideObject() if view else None
    return bool(rendering and rendering.IsA("vtkPVRenderView") and not rendering.GetUseDistributedRenderingForRender())


def query(display, request):
    """The text answer of a request ("summary", "pick X Y", "labels", "colors N"). A display
    that was deleted (Delete, or its source's) answers {"error": ...}: its last data would still
    be there while Python holds it."""
    pxm = sm.ProxyManager().SMProxyManager
    if not pxm.GetProxyName("representations", _smproxy(display)):
        return json.dumps({"error": "the display was deleted (or is not a representation of this session)"})
    # The composite representation exposes the subproxy's own property objects: their parent is
    # the Segmentation Volume subproxy (GetSubProxy is not public).
    sub = _smproxy(display).GetProperty("CSGVMaterials").GetParent()
    q = pxm.NewProxy("misc", "CSGVQuery")
    if _drawn_on_client(_smproxy(display)):
        q.SetLocation(sm.vtkPVSession.CLIENT)  # asked where it was drawn
    sm.vtkSMPropertyHelper(q, "Representation").Set(sub)
    sm.vtkSMPropertyHelper(q, "Request").Set(request)
    q.UpdateVTKObjects()
    q.UpdatePropertyInformation()
    return sm.vtkSMPropertyHelper(q, "Result").GetAsString()


def render_stats(display):
    """The Segmentation Volume's read-only statistics as a dict ({"CSGVMinSamples": 16,
    "CSGVCacheMiB": 12.5, ...}: README, "Read-only statistics"), read from the rendering process
    now (the `render` query: the display's own information properties are read from the client's
    copy, which in client/server never renders, and from one rank only under MPI)."""
    stats = json.loads(query(display, "render"))
    if "error" in stats:
        raise ValueError(stats["error"])
    return stats


def attribute_summary(display):
    """{"attributes": [{"name", "numeric", "min", "max"}...], "labels", "labelArray", "error"}."""
    return json.loads(query(display, "summary"))


def pick(display, x, y):
    """What the last render shows at pixel (x, y) of the view (row 0 at the bottom):
    {"hit", "label", "original", "voxel", "world", "attributes"}. "label" is what materials and
    selections name; on a volume with labels beyond 32 bits that is an id, and "original" (also as
    "originalText") the voxel's own label (README, "Labels beyond 32 bits")."""
    return json.loads(query(display, "pick %d %d" % (x, y)))


def label_image(display):
    """The last render's label image as a numpy uint32 array (rows, columns), row 0 at the
    bottom: the "label" a pick reports at each pixel (the first opaque surface's, else the first
    semi-transparent one's), 0xFFFFFFFF where none. Empty (0 x 0) when the last render drew
    nothing (an error, hidden); RuntimeError for a display that was deleted."""
    import numpy as np
    reply = query(display, "labels")
    if reply.startswith("{"):
        raise RuntimeError(json.loads(reply).get("error", reply))
    w, h, data = (reply.split(" ", 2) + ["", "", ""])[:3]
    w, h = int(w), int(h)
    a = np.frombuffer(base64.b64decode(data), dtype="<u4") if w * h else np.zeros(0, "<u4")
    return a.reshape(h, w)


def label_colors(display, max_labels=4096):
    """{"labels": [[label, r, g, b, name]...], "truncated", "text"}: each label's material colour."""
    return json.loads(query(display, "colors %d" % max_labels))


def _document(text):
    text = (text or "").strip()
    return json.loads(text) if text else json.loads(json.dumps(DEFAULT_DOCUMENT))


def _filter(m):
    f = m.get("filter", {})
    return f.get("attribute", "label"), f.get("min", 1), f.get("max", MAX_LABEL)


def _label_filter(label):
    return {"attribute": "label", "min": label, "max": label}


def hide_label(materials_text, label, attribute=lambda name: None):
    """The material document with `label` hidden. Mirrors Core's csgv::hideLabel
    (Core/include/csgv/materials/Materials.h; the Qt pick panel calls that one): materials
    filtering on `label` whose interval holds it are split around it (the volume keeps its opaque
    pass); when a material filtering on another attribute holds it, or may (`attribute(name)`, the
    label's value of that attribute, is None: unknown), a first material takes the label with
    opacity 0. Testing/ParaView/material_label_edits.json holds both to the same cases."""
    doc = _document(materials_text)
    out = []
    needs_hidden = False
    for m in doc.get("materials", []):
        name, lo, hi = _filter(m)
        v = label if name == "label" else attribute(name)
        if name == "label" and lo <= label <= hi:
            for a, b in ((lo, label - 1), (label + 1, hi)):
                if a <= b:
                    c = json.loads(json.dumps(m))
                    c["filter"] = {"attribute": "label", "min": a, "max": b}
                    out.append(c)
            continue
        if name != "label" and (v is None or lo <= v <= hi):
            needs_hidden = True
        out.append(m)
    if needs_hidden:
        out.insert(0, {"name": "hidden %d" % label, "filter": _label_filter(label),
                       "color": {"mode": "constant", "rgb": [0, 0, 0]}, "opacity": 0})
    doc["materials"] = out
    return json.dumps(doc)


def show_only_label(materials_text, label, attribute=lambda name: None):
    """The material document with only `label` visible, in the colour mode of the material that
    takes it now (the first whose filter holds it; `attribute(name)` gives the label's value of
    an attribute for non-label filters, None when unknown); a new material when none does.
    Mirrors Core's csgv::showOnlyLabel; material_label_edits.json holds both to the same cases."""
    doc = _document(materials_text)
    for m in doc.get("materials", []):
        name, lo, hi = _filter(m)
        v = label if name == "label" else attribute(name)
        if v is not None and lo <= v <= hi:
            c = json.loads(json.dumps(m))
            c["filter"] = _label_filter(label)
            doc["materials"] = [c]
            return json.dumps(doc)
    doc["materials"] = [{"name": "label %d" % label, "filter": _label_filter(label)}]
    return json.dumps(doc)


def select_labels(materials_text, labels, edit="replace", style=None, color=None):
    """The material document with its label selection (the "selected" overlay, drawn by Core's
    csgv::effectiveMaterials; the GUI's pick panel, ParaView's selection tools and the label
    table edit the same key) replaced by, added to or reduced by `labels` (`edit`: "replace",
    "add" or "remove"), optionally with its style ("highlight" or "dim") and highlight colour
    ([r, g, b] in [0, 1]). The materials and the other overlays stay as they are."""
    doc = _document(materials_text)
    have = set(int(x) for x in doc.get("selected", []))
    given = set(int(x) for x in labels)
    if edit == "replace":
        have = given
    elif edit == "add":
        have |= given
    elif edit == "remove":
        have -= given
    else:
        raise ValueError("edit must be 'replace', 'add' or 'remove', not %r" % (edit,))
    if any(x < 0 or x > MAX_LABEL for x in have):
        raise ValueError("labels are integers in [0, %d]" % MAX_LABEL)
    if have:
        doc["selected"] = sorted(have)
    else:
        doc.pop("selected", None)
    if style is not None:
        if style not in ("highlight", "dim"):
            raise ValueError("style must be 'highlight' or 'dim', not %r" % (style,))
        doc["selectionStyle"] = style
    if color is not None:
        doc["selectionColor"] = [float(c) for c in color]
    return json.dumps(doc)


def selected_labels(materials_text):
    """The label selection of a material document, ascending."""
    return sorted(int(x) for x in _document(materials_text).get("selected", []))


def labels_matching(display, condition):
    """The labels (ascending) whose attributes make the SQL `condition` true, e.g.
    `"voxels > 1000 and kind = 2"`: the representation's attribute table (database, loaded,
    computed and derived columns), answered where the data lives. Raises ValueError with SQLite's
    message for a condition it refuses."""
    answer = json.loads(query(display, "match " + condition) or "{}")
    if "error" in answer or "labels" not in answer:
        raise ValueError(answer.get("error", "no answer"))
    return [int(x) for x in answer["labels"]]


def labels_in_rectangle(display, x0, y0, x1, y1):
    """The labels the display's last render shows (what picks report) in the pixel rectangle
    [x0, x1] x [y0, y1] (inclusive, origin bottom left), ascending: what ParaView's rectangle
    selection tools select in the GUI."""
    img = label_image(display)
    ya, yb = sorted((int(y0), int(y1)))
    xa, xb = sorted((int(x0), int(x1)))
    part = img[max(ya, 0):yb + 1, max(xa, 0):xb + 1]
    return sorted(int(x) for x in set(part[part != 0xFFFFFFFF].tolist()))


def apply_label_colors(display, target_display=None, array=None, max_labels=4096):
    """Makes a categorical lookup table of this data's own ("Labels (SOURCE materials)"; the label
    array's shared table is left alone), with each label's material colour and its name (a text
    attribute such as `name`) as annotation, so a Slice or Threshold of the same data
    (target_display, coloured by the array) shows the volume's colours and its legend lists region
    names. Returns the lookup-table proxy."""
    from paraview import simple
    colors = label_colors(display, max_labels)
    if "error" in colors:
        raise RuntimeError(colors["error"])
    name = array or attribute_summary(display).get("labelArray") or "Labels"
    # A table of this data's own, named as the material editor's export names it
    # (pqCSGV::labelColorTableName): the label array's shared table stays as other data use it.
    source = ""
    for (key, _), proxy in simple.GetSources().items():
        if proxy.SMProxy == display.Input.SMProxy:
            source = key
    lut = simple.GetColorTransferFunction(
        "%s (%s materials)" % (name, source) if source else "%s (materials)" % name)
    lut.InterpretValuesAsCategories = 1
    lut.AutomaticRescaleRangeMode = "Never"
    lut.NanOpacity = 0  # label 0, hidden labels and labels no material takes are not drawn
    annotations, indexed, points = [], [], []
    for label, r, g, b, text in colors["labels"]:
        annotations += [str(label), text or str(label)]
        indexed += [r, g, b]
        points += [label, r, g, b]
    lut.Annotations = annotations
    lut.IndexedColors = indexed
    # Read as a continuous map (categories unticked), each label keeps its colour too, as in the
    # material editor's export (pqCSGV::labelColorTable).
    if points:
        # Half a label beyond both ends (pqCSGV::kLabelMargin): a label at the range's end drew
        # the below-range colour on a Slice.
        points = [points[0] - LABEL_MARGIN] + points[1:4] + points + [points[-4] + LABEL_MARGIN] + points[-3:]
        lut.RGBPoints = points
        lut.ColorSpace = "RGB"
        lut.Discretize = 0
        lut.UseBelowRangeColor = 1  # label 0, empty in the volume: grey, not label 1's colour
        lut.BelowRangeColor = [BELOW_LABELS_GREY] * 3
    if target_display is not None:
        simple.ColorBy(target_display, ("CELLS" if _is_cell_array(target_display, name) else "POINTS", name))
        target_display.LookupTable = lut
    return lut


def _is_cell_array(display, name):
    try:
        info = display.Input.GetDataInformation().DataInformation
        return info.GetAttributeInformation(1).GetArrayInformation(name) is not None
    except Exception:
        return True
