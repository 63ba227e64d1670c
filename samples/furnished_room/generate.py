#!/usr/bin/env python3
"""Writes the furnished office room, the discontinuity-meshing test scene of issue 3.

Modelled the way an architect's CAD export arrives: coarse big polygons. A 6 x 5 x 3 m
room (metres, Z up, corner at the origin): walls and ceiling one quad each, the floor a
12 x 10 grid of 0.5 m quads (T-vertices along the wall feet), a table, a chair, an open
shelf 5 mm off the north wall and three 1.2 x 0.3 m ceiling lights facing down.
Faces are counter-clockwise seen from their front. Faces that would coincide with another
(leg tops under the table top, leg bottoms on the floor, board ends against the shelf's
side panels) are left out.
Run from this folder: python3 generate.py
"""

X, Y, Z = 6.0, 5.0, 3.0       # room size, metres
FLOOR_NX, FLOOR_NY = 12, 10    # floor cells (0.5 m)
LIGHT_W, LIGHT_D = 1.2, 0.3    # light size along x and y, metres
LIGHT_Z = 2.98                 # lights 2 cm under the ceiling
LIGHT_X = (1.5, 3.0, 4.5)      # light centres along the long axis, at y = Y / 2
LIGHT_KE = 60.0                # W/m2

# Table: top 1.6 x 0.8 x 0.04 m, its upper face at 0.75 m, legs 0.05 m square
TABLE_X0, TABLE_Y0 = 2.2, 2.1
TABLE_W, TABLE_D, TABLE_H, TABLE_T = 1.6, 0.8, 0.75, 0.04
TABLE_LEG, TABLE_LEG_INSET = 0.05, 0.05
# Chair on the table's south side: seat 0.45 x 0.45 x 0.04 m, its upper face at 0.45 m,
# backrest 0.45 high on the side away from the table, legs 0.04 m square
CHAIR_X0, CHAIR_Y0 = 2.775, 1.55
CHAIR_W, CHAIR_H, CHAIR_T = 0.45, 0.45, 0.04
CHAIR_BACK_T, CHAIR_BACK_H = 0.04, 0.45
CHAIR_LEG, CHAIR_LEG_INSET = 0.04, 0.02
# Open shelf against the north wall: 0.9 wide, 0.35 deep, 1.8 high, 2 cm boards
SHELF_X0, SHELF_GAP = 0.6, 0.005
SHELF_W, SHELF_D, SHELF_H, SHELF_T = 0.9, 0.35, 1.8, 0.02
SHELF_BOTTOM_Z = 0.05          # underside of the bottom board
SHELF_BOARDS = 4               # shelves between bottom and top

MATERIALS = [  # name, Kd, Ke
    ("floor", (0.3, 0.3, 0.3), (0, 0, 0)),
    ("wall", (0.7, 0.7, 0.7), (0, 0, 0)),
    ("ceiling", (0.8, 0.8, 0.8), (0, 0, 0)),
    ("table", (0.45, 0.35, 0.25), (0, 0, 0)),
    ("chair", (0.2, 0.2, 0.2), (0, 0, 0)),
    ("shelf", (0.6, 0.6, 0.6), (0, 0, 0)),
    ("light", (0.0, 0.0, 0.0), (LIGHT_KE, LIGHT_KE, LIGHT_KE)),
]

BOX_FACES = ("-x", "+x", "-y", "+y", "-z", "+z")


def sub(a, b):
    return tuple(p - q for p, q in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def box_faces(x0, x1, y0, y1, z0, z1, omit=()):
    """The faces of an axis-aligned box, outward fronts, without those named in `omit`."""
    faces = {
        "-x": ((x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)),
        "+x": ((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)),
        "-y": ((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)),
        "+y": ((x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)),
        "-z": ((x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)),
        "+z": ((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)),
    }
    assert all(name in BOX_FACES for name in omit)
    return [(faces[name], name) for name in BOX_FACES if name not in omit]


class Model:
    def __init__(self):
        self.faces = []  # (group, material, corners, expected front "+z"/"-x"/...)

    def quad(self, group, mtl, corners, front):
        self.faces.append((group, mtl, tuple(tuple(round(c, 6) for c in p) for p in corners), front))

    def box(self, group, mtl, x0, x1, y0, y1, z0, z1, omit=()):
        for corners, front in box_faces(x0, x1, y0, y1, z0, z1, omit):
            self.quad(group, mtl, corners, front)

    def check(self):
        """Every face a non-degenerate axis-aligned rectangle facing its stated way; no two
        faces of one plane overlapping (coinciding faces hide each other's light)."""
        planes = {}
        for group, _, c, front in self.faces:
            n = cross(sub(c[1], c[0]), sub(c[3], c[0]))
            axis = "xyz".index(front[1])
            assert n[axis] * (1 if front[0] == "+" else -1) > 0, (group, c, front)
            assert all(abs(n[i]) == 0 for i in range(3) if i != axis), (group, c)
            assert len(set(c)) == 4 and all(p[axis] == c[0][axis] for p in c), (group, c)
            rect = [(min(p[i] for p in c), max(p[i] for p in c)) for i in range(3) if i != axis]
            assert all(hi - lo > 1e-9 for lo, hi in rect), (group, c)
            planes.setdefault((axis, c[0][axis]), []).append((rect, group))
        for faces in planes.values():
            for i, (a, ga) in enumerate(faces):
                for b, gb in faces[i + 1:]:
                    overlap = all(min(a[k][1], b[k][1]) - max(a[k][0], b[k][0]) > 1e-9 for k in range(2))
                    assert not overlap, ("coinciding faces", ga, a, gb, b)


def build():
    m = Model()

    # Floor: a grid of 0.5 m quads facing up (+z)
    dx, dy = X / FLOOR_NX, Y / FLOOR_NY
    for j in range(FLOOR_NY):
        for i in range(FLOOR_NX):
            x0, y0 = i * dx, j * dy
            m.quad("floor", "floor", ((x0, y0, 0), (x0 + dx, y0, 0), (x0 + dx, y0 + dy, 0), (x0, y0 + dy, 0)), "+z")
    # Ceiling facing down, walls facing in: one quad each
    m.quad("ceiling", "ceiling", ((0, 0, Z), (0, Y, Z), (X, Y, Z), (X, 0, Z)), "-z")
    m.quad("wall_south", "wall", ((X, 0, 0), (0, 0, 0), (0, 0, Z), (X, 0, Z)), "+y")
    m.quad("wall_north", "wall", ((0, Y, 0), (X, Y, 0), (X, Y, Z), (0, Y, Z)), "-y")
    m.quad("wall_west", "wall", ((0, 0, 0), (0, Y, 0), (0, Y, Z), (0, 0, Z)), "+x")
    m.quad("wall_east", "wall", ((X, Y, 0), (X, 0, 0), (X, 0, Z), (X, Y, Z)), "-x")

    # Table: a closed top, legs from the floor to the top's underside (no top or bottom faces)
    x0, y0, x1, y1 = TABLE_X0, TABLE_Y0, TABLE_X0 + TABLE_W, TABLE_Y0 + TABLE_D
    under = TABLE_H - TABLE_T
    m.box("table", "table", x0, x1, y0, y1, under, TABLE_H)
    for lx in (x0 + TABLE_LEG_INSET, x1 - TABLE_LEG_INSET - TABLE_LEG):
        for ly in (y0 + TABLE_LEG_INSET, y1 - TABLE_LEG_INSET - TABLE_LEG):
            m.box("table", "table", lx, lx + TABLE_LEG, ly, ly + TABLE_LEG, 0, under, omit=("-z", "+z"))

    # Chair: seat, backrest standing on the seat's south edge (no bottom face), legs
    x0, y0, x1, y1 = CHAIR_X0, CHAIR_Y0, CHAIR_X0 + CHAIR_W, CHAIR_Y0 + CHAIR_W
    under = CHAIR_H - CHAIR_T
    m.box("chair", "chair", x0, x1, y0, y1, under, CHAIR_H)
    m.box("chair", "chair", x0, x1, y0, y0 + CHAIR_BACK_T, CHAIR_H, CHAIR_H + CHAIR_BACK_H, omit=("-z",))
    for lx in (x0 + CHAIR_LEG_INSET, x1 - CHAIR_LEG_INSET - CHAIR_LEG):
        for ly in (y0 + CHAIR_LEG_INSET, y1 - CHAIR_LEG_INSET - CHAIR_LEG):
            m.box("chair", "chair", lx, lx + CHAIR_LEG, ly, ly + CHAIR_LEG, 0, under, omit=("-z", "+z"))

    # Shelf: side panels standing on the floor, boards between them (no end faces), no back
    x0, x1 = SHELF_X0, SHELF_X0 + SHELF_W
    y1 = Y - SHELF_GAP
    y0 = y1 - SHELF_D
    m.box("shelf", "shelf", x0, x0 + SHELF_T, y0, y1, 0, SHELF_H, omit=("-z",))
    m.box("shelf", "shelf", x1 - SHELF_T, x1, y0, y1, 0, SHELF_H, omit=("-z",))
    top = SHELF_H - SHELF_T
    pitch = (top - (SHELF_BOTTOM_Z + SHELF_T)) / (SHELF_BOARDS + 1)  # clear height + board
    heights = [SHELF_BOTTOM_Z] + [SHELF_BOTTOM_Z + SHELF_T + k * pitch for k in range(1, SHELF_BOARDS + 1)] + [top]
    for z in heights:
        z = round(z, 3)
        m.box("shelf", "shelf", x0 + SHELF_T, x1 - SHELF_T, y0, y1, z, z + SHELF_T, omit=("-x", "+x"))

    # Ceiling lights: one quad each, emitting downward (front -z)
    for k, cx in enumerate(LIGHT_X, 1):
        lx0, lx1 = cx - LIGHT_W / 2, cx + LIGHT_W / 2
        ly0, ly1 = Y / 2 - LIGHT_D / 2, Y / 2 + LIGHT_D / 2
        m.quad(f"light_{k}", "light", ((lx0, ly0, LIGHT_Z), (lx0, ly1, LIGHT_Z), (lx1, ly1, LIGHT_Z), (lx1, ly0, LIGHT_Z)), "-z")

    m.check()
    return m


def number(x):
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def write_obj(path, m):
    index, v, f = {}, [], []
    for group, mtl, corners, _ in m.faces:
        ids = []
        for p in corners:
            if p not in index:  # shared vertices, as an indexed CAD export writes them
                index[p] = len(v) + 1
                v.append(p)
            ids.append(index[p])
        f.append((group, mtl, ids))
    with open(path, "w") as out:
        out.write("# abrad sample: a furnished office room (issue 3, discontinuity meshing)\n")
        out.write("# generated by generate.py; metres, Z up\nmtllib furnished_room.mtl\n")
        for p in v:
            out.write("v " + " ".join(number(c) for c in p) + "\n")
        current = None
        for group, mtl, ids in f:
            if (group, mtl) != current:
                out.write(f"g {group}\nusemtl {mtl}\n")
                current = (group, mtl)
            out.write("f " + " ".join(str(i) for i in ids) + "\n")
    return len(v), len(f)


with open("furnished_room.mtl", "w") as out:
    out.write("# abrad sample materials: Kd = reflectance, Ke = emittance W/m2, d = opacity\n")
    for name, kd, ke in MATERIALS:
        out.write(f"newmtl {name}\nKd {kd[0]} {kd[1]} {kd[2]}\nKe {ke[0]} {ke[1]} {ke[2]}\nd 1\n")
vertices, quads = write_obj("furnished_room.obj", build())
print(f"furnished_room.obj: {vertices} vertices, {quads} quads ({2 * quads} triangles)")
