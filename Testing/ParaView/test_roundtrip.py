# SPDX-License-Identifier: MIT
"""Writer -> reader round trips through SaveData/OpenDataFile with exact equality of labels,
types (8 to 64 bit, signed or not, floats holding integers) and geometry; relabelling when
labels do not fit the format; errors for non-integer floats; writer properties."""
import json
import os
import struct

import numpy as np

import csgv_pvtest as t
from paraview.simple import *
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData

t.load_plugin(globals())
tmp = t.temp_dir()
rng = np.random.default_rng(7)
W, H, D = 37, 23, 19


def blocky(values):
    """A segmentation-like volume (D, H, W): boxes of labels drawn from `values`."""
    idx = rng.integers(0, len(values), size=(D // 4 + 1, H // 4 + 1, W // 4 + 1))
    idx = idx.repeat(4, 0).repeat(4, 1).repeat(4, 2)[:D, :H, :W]
    return np.asarray(values)[idx]


def image(arrays, cell=True, origin=(0, 0, 0), spacing=(1, 1, 1), direction=None, first=(0, 0, 0)):
    img = vtkImageData()
    n = (W + 1, H + 1, D + 1) if cell else (W, H, D)
    img.SetExtent(first[0], first[0] + n[0] - 1, first[1], first[1] + n[1] - 1, first[2], first[2] + n[2] - 1)
    img.SetOrigin(origin)
    img.SetSpacing(spacing)
    if direction is not None:
        img.SetDirectionMatrix(direction)
    attrs = img.GetCellData() if cell else img.GetPointData()
    for name, a in arrays:
        va = numpy_to_vtk(np.ascontiguousarray(a).ravel(), deep=1)
        va.SetName(name)
        attrs.AddArray(va)
    return img


def producer(img):
    p = PVTrivialProducer()
    p.GetClientSideObject().SetOutput(img)
    return p


def roundtrip(tag, img, **writer):
    path = os.path.join(tmp, tag + ".csgv")
    src = producer(img)
    SaveData(path, proxy=src, **writer)
    Delete(src)
    if not os.path.exists(path):
        return path, None
    r = CSGVReader(FileName=path)
    out = t.fetch(r)
    Delete(r)
    return path, out


def check_case(tag, labels, relabelled, **writer):
    path, out = roundtrip(tag, image([("seg", labels)]), **writer)
    t.check(out is not None, tag + ": written and read")
    if out is None:
        return None
    got = t.cell_labels(out)
    t.check(got is not None and got.dtype == labels.dtype, tag + ": type %s kept (got %s)" % (labels.dtype, None if got is None else got.dtype))
    t.check(got is not None and np.array_equal(got, labels.ravel()), tag + ": labels equal")
    t.check(os.path.exists(path[:-5] + "_csgv.db3") == relabelled, tag + ": attribute database %s" % ("written" if relabelled else "absent"))
    md = json.load(open(path + ".json"))
    t.check(md["original_type"] == {"u1": "uint8", "i1": "int8", "u2": "uint16", "i2": "int16", "u4": "uint32",
                                    "i4": "int32", "u8": "uint64", "i8": "int64", "f4": "float32",
                                    "f8": "float64"}[labels.dtype.str[1:]], tag + ": metadata original_type")
    return out


i64 = np.iinfo(np.int64)
check_case("uint8", blocky(np.array([0, 3, 200, 255], np.uint8)), False)
check_case("int8", blocky(np.array([0, -128, 5, 127], np.int8)), True)
check_case("uint16", blocky(np.array([0, 1, 65535, 300], np.uint16)), False)
check_case("int16_negative", blocky(np.array([0, -1, -32768, 32767, 12], np.int16)), True)
check_case("uint32_reserved", blocky(np.array([0, 0xFFFFFFFF, 0xFFFFFFFE, 7], np.uint32)), True)
check_case("int32", blocky(np.array([0, 2**31 - 1, 44, 9], np.int32)), False)
check_case("int64_wide", blocky(np.array([0, i64.min, i64.max, -(2**40), 2**40 + 3], np.int64)), True)
check_case("uint64_wide", blocky(np.array([0, 2**64 - 1, 2**63, 2**32, 1], np.uint64)), True)
check_case("uint64_narrow", blocky(np.array([0, 5, 2**32 - 2], np.uint64)), False)
check_case("float32_integers", blocky(np.array([0, 1, 2**24, 77], np.float32)), False)
check_case("float64_negative", blocky(np.array([0, -5, 2**40, 3], np.float64)), True)
check_case("relabel_forced", blocky(np.array([0, 9, 1000], np.uint32)), True, Relabel=1)

# Geometry: cell data keeps origin/spacing/direction; an extent that does not start at 0 moves
# the origin to the first cell's corner.
rot = [0, -1, 0, 1, 0, 0, 0, 0, 1]
labels = blocky(np.array([0, 1, 2], np.uint16))
_, out = roundtrip("geometry_cell", image([("seg", labels)], origin=(1, 2, 3), spacing=(0.5, 1.5, 2), direction=rot,
                                          first=(2, 0, 0)))
t.check(np.allclose(out.GetSpacing(), (0.5, 1.5, 2)), "cell geometry: spacing kept")
t.check(np.allclose(out.GetOrigin(), (1, 2 + 2 * 0.5, 3)), "cell geometry: origin at the first cell's corner (%s)" % (out.GetOrigin(),))
m = out.GetDirectionMatrix()
t.check([m.GetElement(r, c) for r in range(3) for c in range(3)] == rot, "cell geometry: direction kept")

# Point data: voxels centred on points, so the cell image starts half a voxel earlier.
_, out = roundtrip("geometry_point", image([("seg", labels)], cell=False, origin=(-90, -125, -71), spacing=(2, 2, 2)))
t.check(np.allclose(out.GetOrigin(), (-91, -126, -72)), "point geometry: origin moved half a voxel (%s)" % (out.GetOrigin(),))
t.check(np.array_equal(t.cell_labels(out), labels.ravel()), "point data: labels equal")

# Choosing the array: default is the first integer array (a float intensity is skipped).
intensity = rng.random((D, H, W))
seg2 = blocky(np.array([0, 4, 8], np.int32))
img = image([("intensity", intensity), ("seg", labels), ("other", seg2)])
_, out = roundtrip("choose_default", img)
t.check(np.array_equal(t.cell_labels(out), labels.ravel()), "default label array: first integer array")
_, out = roundtrip("choose_named", img, LabelArrayName="other")
t.check(np.array_equal(t.cell_labels(out), seg2.ravel()), "LabelArrayName picks 'other'")

# A float array that is not integral: an error naming the voxel, no file.
bad = blocky(np.array([0.0, 1.0, 2.0]))
bad[3, 2, 1] = 0.5
with t.ErrorLog() as errors:
    path, out = roundtrip("float_fraction", image([("seg", bad)]))
t.check(out is None and not os.path.exists(path), "non-integer float: nothing written")
t.check("voxel (1, 2, 3)" in errors.text and "0.5" in errors.text, "non-integer float: error names the voxel and value")

# Writer properties reach the file header (CSGV-FORMAT: brick size at byte 12, encoding at 28).
path, out = roundtrip("props", image([("seg", labels)]), BrickSize=16, Encoding=0, Operations="all")
head = open(path, "rb").read(41)
brick, enc, mask = struct.unpack_from("<I", head, 12)[0], struct.unpack_from("<i", head, 28)[0], struct.unpack_from("<I", head, 37)[0]
t.check((brick, enc, mask) == (16, 0, 0x1AF), "BrickSize/Encoding/Operations in the header (%d, %d, 0x%x)" % (brick, enc, mask))
t.check(np.array_equal(t.cell_labels(out), labels.ravel()), "props: labels equal")

# An encoding the format does not have is refused, naming it (it was written as another).
with t.ErrorLog() as errors:
    path, out = roundtrip("bad_encoding", image([("seg", labels)]), Encoding=99)
t.check(out is None and not os.path.exists(path) and "encoding 99" in errors.text,
        "Encoding 99: refused with a message naming it (%s)" % errors.text.strip()[:200])

# A save over an existing set that fails on a full disk (a file size limit here: the new volume
# cannot be written, its small sidecars could) leaves the old volume, metadata and attribute
# database byte-identical, so the old set opens with its own labels; the error names the volume,
# not its temporary.
import resource
import signal

old_labels = blocky(np.array([-5, 3, 2 ** 40], dtype=np.int64))  # relabelled: a database
path, out = roundtrip("full_disk", image([("seg", old_labels)]))
old_set = {p: open(p, "rb").read() for p in (path, path + ".json", path[:-5] + "_csgv.db3")}
big = np.random.default_rng(3).integers(-100, 100, size=(64, 64, 64)).astype(np.int64) * (2 ** 33)
img = vtkImageData()
img.SetDimensions(65, 65, 65)
va = numpy_to_vtk(big.ravel(), deep=1)
va.SetName("seg")
img.GetCellData().AddArray(va)
limit = 48 * 1024  # above the new metadata and database, below the new volume
soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes past the limit fail (EFBIG), as on a full disk
src = producer(img)
with t.ErrorLog() as errors:
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        SaveData(path, proxy=src)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
Delete(src)
t.check(errors.text.strip() != "", "full disk: the save reports an error")
t.check(".tmp-" not in errors.text and os.path.basename(path) in errors.text,
        "full disk: the error names the volume, not its temporary (%s)" % errors.text.strip()[:200])
for p, data in old_set.items():
    t.check(open(p, "rb").read() == data, "full disk: %s unchanged" % os.path.basename(p))
r = CSGVReader(FileName=path)
again = t.fetch(r)
Delete(r)
t.check(np.array_equal(t.cell_labels(again), old_labels.ravel()), "full disk: the old set opens with its own labels")

t.check(len([f for f in os.listdir(tmp) if ".tmp" in f]) == 0, "no temporary files left behind")
t.finish()
