#!/usr/bin/env bash
# Seeds the libFuzzer corpora from assets/ (plus a few small hand-written inputs) into DIR
# (default build-fuzz/corpus): one folder per fuzz target. Corpora are not committed.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
dir="${1:-$root/build-fuzz/corpus}"
mkdir -p "$dir"/{tetgen_fuzz,gmsh_fuzz,vtk_legacy_fuzz,scene_fuzz,tool_script_fuzz,pose_stream_fuzz}
m="$root/assets/meshes"

# TetGen: .node, a NUL byte, .ele (tetgen_fuzz.cpp splits there).
{ cat "$m/tetgen_box.node"; printf '\0'; cat "$m/tetgen_box.ele"; } > "$dir/tetgen_fuzz/box"
printf '4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n\0001 4 0\n0 0 1 2 3\n' > "$dir/tetgen_fuzz/one_tet"
printf '# comment\n4 3 1 1\n1 0 0 0 5 1\n2 1 0 0 5 1\n3 0 1 0 5 0\n4 0 0 1 5 0\n\0001 4 1\n1 1 2 3 4 7\n' \
  > "$dir/tetgen_fuzz/one_tet_attr"

cp "$m/gmsh_cube_v22.msh" "$m/gmsh_cube_v41.msh" "$dir/gmsh_fuzz/"
cp "$m/gmsh_cube.vtk" "$m/tetgen_box.vtk" "$dir/vtk_legacy_fuzz/"

cp "$root"/assets/scenes/*.json "$dir/scene_fuzz/"
# A small scene naming a mesh file relative to assets/scenes, and one with a script file.
cat > "$dir/scene_fuzz/file_mesh.json" <<'J'
{"bodies": [{"name": "b", "mesh": {"file": "../meshes/tetgen_box.node"}, "kinematic": true}],
 "instruments": [{"name": "probe", "type": "probe"}], "contact": {"method": "penalty"}}
J

# Tool scripts: the script arrays of the shipped scenes, and every operation once.
for s in "$root"/assets/scenes/*.json; do
  python3 -c 'import json,sys; print(json.dumps(json.load(open(sys.argv[1])).get("script", [])))' "$s" \
    > "$dir/tool_script_fuzz/$(basename "$s")"
done
cat > "$dir/tool_script_fuzz/all_ops.json" <<'J'
[{"t": 0.5, "instrument": "probe", "op": "move", "position": [0, 0, 0.1], "orientation": [1, 0, 0, 0]},
 {"t": 1.0, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "depth": 0.004},
 {"t": 2.0, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "force": 1.5, "speed": 0.01, "max_depth": 0.01, "ramp": 0.02},
 {"t": 3.0, "instrument": "probe", "op": "hold"},
 {"t": 4.0, "instrument": "probe", "op": "slide", "path": [[0.01, 0, 0], [0.02, 0.01, 0]]},
 {"t": 5.0, "instrument": "probe", "op": "rotate", "axis": [0, 1, 0], "angle_deg": 30},
 {"t": 1.0, "instrument": "grasper", "op": "jaws", "opening_deg": 40}]
J

# Pose streams.
cat > "$dir/pose_stream_fuzz/two_instruments.csv" <<'J'
# t,instrument,x,y,z,qw,qx,qy,qz[,jaw]
0,probe,0,0,0.05,1,0,0,0
0.5,probe,0,0,0.04,1,0,0,0
1,probe,0.01,0,0.03,0.7071,0,0.7071,0
0,grasper,0,0,0.1,1,0,0,0,0.3
1.5,grasper,0,0,0.1,1,0,0,0,0.1
J
printf '0,probe,1e-3,-2.5e-2,3,1,0,0,0\n\n#x\n2,probe,0,0,0,0,0,0,1,0.5\n' > "$dir/pose_stream_fuzz/sparse.csv"
echo "corpora in $dir"
