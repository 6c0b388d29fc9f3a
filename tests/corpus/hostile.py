#!/usr/bin/env python3
"""Writes the hand-made hostile VTU files of tests/corpus/vtu/ (the fuzzers' finds are added
beside them as they come). Each is a one-triangle file whose Points array lies about its size.
Run from this folder: python3 hostile.py"""
import base64
import lzma
import struct
import zlib

POINTS = struct.pack("<9d", 0, 0, 0, 1, 0, 0, 0, 1, 0)


def vtu(points_xml, npoints=3, compressor="", header="UInt64"):
    comp = f' compressor="{compressor}"' if compressor else ""
    return f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="{header}"{comp}>
  <UnstructuredGrid>
    <Piece NumberOfPoints="{npoints}" NumberOfCells="1">
      <Points>
        {points_xml}
      </Points>
      <Cells>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">3</DataArray>
        <DataArray type="UInt8" Name="types" format="ascii">5</DataArray>
      </Cells>
    </Piece>
  </UnstructuredGrid>
</VTKFile>
"""


def binary(payload):
    return ('<DataArray type="Float64" NumberOfComponents="3" format="binary">'
            + base64.b64encode(payload).decode() + "</DataArray>")


def blocks(header_ints, data, fmt="<Q"):
    return b"".join(struct.pack(fmt, v) for v in header_ints) + data


files = {}
# An xz stream of 2 MiB declared as the 72 bytes of the points.
xz = lzma.compress(bytes(2 << 20), format=lzma.FORMAT_XZ, check=lzma.CHECK_CRC64)
files["lzma_bomb"] = vtu(binary(blocks([1, 72, 0, len(xz)], xz)), compressor="vtkLZMADataCompressor")
# A zlib block of 2 MiB of zeros declared as 72 bytes.
z = zlib.compress(bytes(2 << 20))
files["zlib_bomb"] = vtu(binary(blocks([1, 72, 0, len(z)], z)), compressor="vtkZLibDataCompressor")
# 10^11 points declared, with a compression header that agrees and 40 bytes of data.
n = 10**11
z = zlib.compress(POINTS)
files["zlib_huge_declared"] = vtu(
    binary(blocks([1, 24 * n, 0, len(z)], z)), npoints=n, compressor="vtkZLibDataCompressor")
# 2^32 − 1 compressed blocks declared in a UInt32 header.
files["block_count_huge"] = vtu(
    binary(blocks([2**32 - 1, 72, 0], b"", fmt="<I")), compressor="vtkZLibDataCompressor",
    header="UInt32")
# 2^64 − 1 points: the byte count overflows.
files["points_count_overflow"] = vtu(
    '<DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0</DataArray>',
    npoints=2**64 - 1)
# 10^12 points declared for three ASCII values.
files["ascii_huge_declared"] = vtu(
    '<DataArray type="Float64" NumberOfComponents="3" format="ascii">0 0 0</DataArray>',
    npoints=10**12)
# An uncompressed header declaring 2^64 − 1 bytes.
files["raw_header_huge"] = vtu(binary(blocks([2**64 - 1], POINTS)))

for name, text in files.items():
    with open(f"vtu/{name}.vtu", "w") as f:
        f.write(text)
