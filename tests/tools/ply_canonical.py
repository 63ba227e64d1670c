#!/usr/bin/env python3
"""Canonical text of an ASCII PLY that abrad exported: its vertex lines sorted, then its
triangles as sorted triples of their corners' positions, sorted. Two exports with the same
vertices (every property, to the printed digit) and the same triangles give the same text,
whatever order the mesher numbered the vertices in.

Usage: ply_canonical.py IN.ply OUT.txt"""
import sys


def main(path_in, path_out):
    with open(path_in, encoding="ascii") as f:
        lines = f.read().split("\n")
    end = lines.index("end_header")
    count = {}
    for line in lines[:end]:
        words = line.split()
        if words[:1] == ["element"]:
            count[words[1]] = int(words[2])
    vertices = lines[end + 1:end + 1 + count["vertex"]]
    faces = lines[end + 1 + count["vertex"]:end + 1 + count["vertex"] + count["face"]]
    position = [" ".join(v.split()[:3]) for v in vertices]
    triangles = []
    for face in faces:
        words = face.split()
        corners = [position[int(i)] for i in words[1:1 + int(words[0])]]
        triangles.append(" | ".join(sorted(corners)) + " | " + " ".join(words[1 + int(words[0]):]))
    with open(path_out, "w", encoding="ascii") as out:
        out.write("\n".join(sorted(vertices)) + "\n")
        out.write("\n".join(sorted(triangles)) + "\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
