#!/usr/bin/env bash
# Regenerates the small reference meshes in assets/meshes/ with Debian's gmsh and tetgen, so the
# readers are tested on files written by the real tools (not only by our own writers).
#   gmsh_cube_v22.msh, gmsh_cube_v41.msh, gmsh_cube.vtk: the same gmsh mesh of a 0.1 m cube
#     (physical volume 7 "tissue", physical surface 3 "skin") in MSH 2.2, MSH 4.1 and legacy VTK.
#   tetgen_box.node/.ele (+ tetgen_box.vtk): tetgen -pq1.5a5e-5A of a 0.1 m box, region attribute 7.
# Usage: scripts/make_meshes.sh   (from the repository root; needs gmsh and tetgen on PATH)
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
out="$root/assets/meshes"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"

# --- gmsh: one .geo, three output formats -------------------------------------------------------
cat > "$work/cube.geo" <<'GEO'
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.1, 0.1, 0.1};
Physical Volume("tissue", 7) = {1};
Physical Surface("skin", 3) = {1, 2, 3, 4, 5, 6};
Mesh.MeshSizeMax = 0.05;
Mesh.MeshSizeMin = 0.05;
GEO
# Mesh once, then save that one mesh in each format, so all three hold the same tetrahedra.
gmsh -3 -format msh41 -o "$work/cube_v41.msh" "$work/cube.geo" > "$work/gmsh.log"
gmsh "$work/cube_v41.msh" -format msh22 -save -o "$work/cube_v22.msh" >> "$work/gmsh.log"
gmsh "$work/cube_v41.msh" -format vtk -save -o "$work/cube.vtk" >> "$work/gmsh.log"
cp "$work/cube_v41.msh" "$out/gmsh_cube_v41.msh"
cp "$work/cube_v22.msh" "$out/gmsh_cube_v22.msh"
cp "$work/cube.vtk" "$out/gmsh_cube.vtk"

# --- tetgen: a .poly box with one region (attribute 7) ----------------------------------------
cat > "$work/box.poly" <<'POLY'
# 0.1 m box: 8 corners, 6 quadrilateral facets, no holes, one region with attribute 7
8 3 0 0
1 0 0 0
2 0.1 0 0
3 0.1 0.1 0
4 0 0.1 0
5 0 0 0.1
6 0.1 0 0.1
7 0.1 0.1 0.1
8 0 0.1 0.1
6 0
1
4 1 2 3 4
1
4 5 6 7 8
1
4 1 2 6 5
1
4 2 3 7 6
1
4 3 4 8 7
1
4 4 1 5 8
0
1
1 0.05 0.05 0.05 7
POLY
# -p: tetrahedralize the PLC, -q1.5: radius-edge bound, -a: max volume (m^3), -A: region
# attributes, -k: also write .vtk, -Q: quiet.
tetgen -pq1.5a5e-5AkQ "$work/box.poly"
cp "$work/box.1.node" "$out/tetgen_box.node"
cp "$work/box.1.ele" "$out/tetgen_box.ele"
cp "$work/box.1.vtk" "$out/tetgen_box.vtk"
ls -l "$out"
