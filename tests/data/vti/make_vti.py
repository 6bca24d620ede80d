#!/usr/bin/python3
"""Writes the .vti fixtures of tests/unit/test_vti.c with VTK's own writer
(vtkXMLImageDataWriter, Debian's python3-vtk9), so the reader is tested
against files the field's reference implementation produces.

Every file holds a 7x5x3 grid, extent x 2..8, y -1..3, z 0..2, spacing
(0.5, 1, 2), origin (10, 20, 30), with one or two point arrays whose values
follow the formulas in test_vti.c (value_u8 / value_i16 / value_f32).
Usage: /usr/bin/python3 make_vti.py [out_dir]
"""
import math
import os
import sys

import vtk

NX, NY, NZ = 7, 5, 3


def value_u8(i, j, k):
    return (3 * i + 5 * j + 11 * k) % 256


def value_i16(i, j, k):
    return 100 * i - 300 * j + 1000 * k


def value_f32(i, j, k):
    return 0.25 * i - 1.5 * j + 7.0 * k + 0.125


def value_u32(i, j, k):
    # near 2^32, multiples of 256: exact in float32 (24-bit significand)
    return 4026531840 + 256 * (i + 7 * j + 35 * k)


def value_i64(i, j, k):
    # beyond 2^32 on both sides, multiples of 2^17: exact in float32 near 2^40
    return -(1 << 40) + 131072 * (3 * i - 5 * j + 11 * k)


def image(arrays):
    img = vtk.vtkImageData()
    img.SetExtent(2, 2 + NX - 1, -1, -1 + NY - 1, 0, NZ - 1)
    img.SetSpacing(0.5, 1.0, 2.0)
    img.SetOrigin(10.0, 20.0, 30.0)
    for name, kind in arrays:
        a = {"u8": vtk.vtkUnsignedCharArray, "i16": vtk.vtkShortArray, "f32": vtk.vtkFloatArray,
             "f64": vtk.vtkDoubleArray, "i32": vtk.vtkIntArray, "u32": vtk.vtkUnsignedIntArray,
             "i64": vtk.vtkLongLongArray, "u64": vtk.vtkUnsignedLongLongArray}[kind]()
        a.SetName(name)
        a.SetNumberOfTuples(NX * NY * NZ)
        f = {"u8": value_u8, "i16": value_i16, "f32": value_f32, "f64": value_f32, "i32": value_i16,
             "u32": value_u32, "i64": value_i64, "u64": value_u32}[kind]
        n = 0
        for k in range(NZ):
            for j in range(NY):
                for i in range(NX):
                    a.SetValue(n, f(i, j, k))
                    n += 1
        img.GetPointData().AddArray(a)
    img.GetPointData().SetActiveScalars(arrays[-1][0])
    return img


def write(path, img, mode, zlib=False, header64=False, big=False, encode=False, block=None):
    w = vtk.vtkXMLImageDataWriter()
    w.SetFileName(path)
    w.SetInputData(img)
    {"ascii": w.SetDataModeToAscii, "binary": w.SetDataModeToBinary, "appended": w.SetDataModeToAppended}[mode]()
    if zlib:
        w.SetCompressorTypeToZLib()
        if block:
            w.SetBlockSize(block)
    else:
        w.SetCompressorTypeToNone()
    w.SetHeaderTypeToUInt64() if header64 else w.SetHeaderTypeToUInt32()
    w.SetByteOrderToBigEndian() if big else w.SetByteOrderToLittleEndian()
    w.SetEncodeAppendedData(1 if encode else 0)
    assert w.Write() == 1, path


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    f32 = image([("density", "f32")])
    two = image([("other", "f32"), ("density", "u8")])  # Scalars names the second
    write(f"{out}/ascii_f32.vti", f32, "ascii")
    write(f"{out}/binary_f32.vti", f32, "binary")
    write(f"{out}/binary_zlib_f32.vti", f32, "binary", zlib=True, block=64)
    write(f"{out}/appended_f32.vti", f32, "appended")
    write(f"{out}/appended_zlib_u64_f32.vti", f32, "appended", zlib=True, header64=True, block=100)
    write(f"{out}/appended_b64_zlib_f32.vti", f32, "appended", zlib=True, encode=True, block=64)
    write(f"{out}/big_endian_i16.vti", image([("density", "i16")]), "appended", big=True)
    write(f"{out}/ascii_i16.vti", image([("density", "i16")]), "ascii")
    write(f"{out}/binary_f64.vti", image([("density", "f64")]), "binary", zlib=True)
    write(f"{out}/two_arrays_u8.vti", two, "appended", zlib=True)
    write(f"{out}/int32.vti", image([("density", "i32")]), "binary")
    write(f"{out}/ascii_u32.vti", image([("density", "u32")]), "ascii")
    write(f"{out}/appended_zlib_i64.vti", image([("density", "i64")]), "appended", zlib=True, block=64)
    write(f"{out}/big_endian_u64.vti", image([("density", "u64")]), "binary", big=True)


if __name__ == "__main__":
    main()
