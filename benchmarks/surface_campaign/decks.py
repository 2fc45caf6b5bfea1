"""Decks and fixtures of the surface campaign: a tiny base deck, a YAML writer that keeps NaN and
inf, and the files made once (meshes, a checkpointed run, a result file, an XML deck)."""
from __future__ import annotations

import copy
import json
import math
import shutil
from pathlib import Path
from typing import Any

#: 10 x 4 x 4 points, 1 mm spacing, LPS steel: 13 Verlet steps, a fraction of a second
BASE: dict = {
    "Discretization": {
        "Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
        "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": 0.0, "Y Origin": 0.0, "Z Origin": 0.0,
                                          "X Length": 0.010, "Y Length": 0.004, "Z Length": 0.004,
                                          "Number Points X": 10, "Number Points Y": 4, "Number Points Z": 4}},
    "Materials": {"Steel": {"Material Model": "Elastic", "Density": 7800.0, "Young's Modulus": 200.0e9, "Poisson's Ratio": 0.3}},
    "Blocks": {"B": {"Block Names": "block_1", "Material": "Steel", "Horizon": 0.003015}},
    "Boundary Conditions": {
        "Left Node Set": {"Half Space": {"Point": [0.002, 0.0, 0.0], "Normal": [-1.0, 0.0, 0.0]}},
        "Right Node Set": {"Intersection": {"Layer": {"Surface Layer": {"Thickness": 0.001}},
                                            "End": {"Half Space": {"Point": [0.009, 0.0, 0.0], "Normal": [1.0, 0.0, 0.0]}}}},
        "Hold": {"Type": "Prescribed Displacement", "Node Set": "Left Node Set", "Coordinate": "x", "Value": "0.0"},
        "Pull": {"Type": "Surface Traction", "Node Set": "Right Node Set", "Traction": [1.0e6, 0.0, 0.0], "Scale": "min(t/1.0e-6, 1.0)"},
    },
    "Solver": {"Initial Time": 0.0, "Final Time": 2.0e-6, "Verlet": {"Safety Factor": 0.8}},
    "Output": {"Output Filename": "base", "Output Frequency": 5, "Output Variables": {"Displacement": True, "Velocity": True}},
}
RESTART = {"Restart Frequency": 5, "Folder": "restart", "Keep": 3}


def base(**changes: Any) -> dict:
    d = copy.deepcopy(BASE)
    for k, v in changes.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


def _scalar(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if math.isnan(v):
            return ".nan"
        if math.isinf(v):
            return ".inf" if v > 0 else "-.inf"
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if v is None:
        return "null"
    if isinstance(v, Raw):
        return v.text
    return json.dumps(str(v))


class Raw:
    """Text written into the YAML as it is."""

    def __init__(self, text: str) -> None:
        self.text = text


def _flow(v: Any) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))}: {_flow(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_flow(x) for x in v) + "]"
    return _scalar(v)


def to_yaml(tree: dict, indent: int = 0, flow_depth: int = 12) -> str:
    """Block-style YAML (flow style below ``flow_depth`` levels), NaN and inf as YAML writes them."""
    out = []
    pad = "  " * indent
    for k, v in tree.items():
        key = json.dumps(str(k))
        if isinstance(v, dict) and v and indent < flow_depth:
            out.append(f"{pad}{key}:\n" + to_yaml(v, indent + 1, flow_depth))
        else:
            out.append(f"{pad}{key}: {_flow(v) if not isinstance(v, dict) or v else '{}'}\n")
    return "".join(out)


def write_deck(folder: Path, tree: dict, name: str = "deck.yaml", root: bool = True) -> Path:
    path = folder / name
    path.write_text(to_yaml({"Peridigm": tree} if root else tree))
    return path


# ------------------------------------------------------------------------------------------------
# Fixtures made once
# ------------------------------------------------------------------------------------------------
GEO_BOX = """// a 10 x 4 x 4 mm box
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 10, 4, 4};
Physical Volume("Body") = {1};
Mesh.MeshSizeMax = 2.0;
"""


def mesh_deck(mesh_name: str, **disc: Any) -> dict:
    d = base()
    d["Discretization"] = {"Type": "Mesh", "Input Mesh File": mesh_name, "Length Scale": 0.001, **disc}
    names = "Body" if str(mesh_name).endswith(".geo") else "block_1"
    d["Blocks"] = {"B": {"Block Names": names, "Material": "Steel", "Horizon": 0.003}}
    d["Boundary Conditions"] = {"All Node Set": {"All": True},
                                "Kick": {"Type": "Initial Velocity", "Node Set": "All Node Set", "Coordinate": "x", "Value": "0.1*x"}}
    d["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0e-6, "Verlet": {"Safety Factor": 0.8}}
    return d


def make_meshes(folder: Path) -> dict[str, Path]:
    """Valid small tet and hex meshes in .msh, .inp, .vtu, .vtk (gmsh, then meshio)."""
    import gmsh
    import meshio

    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, Path] = {}
    for kind in ("tet", "hex"):
        gmsh.initialize(["-nt", "1"])
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(kind)
            if kind == "tet":
                gmsh.model.occ.addBox(0, 0, 0, 10, 4, 4)
                gmsh.model.occ.synchronize()
                gmsh.option.setNumber("Mesh.MeshSizeMax", 2.0)
            else:
                p = gmsh.model.geo.addPoint(0, 0, 0)
                l1 = gmsh.model.geo.extrude([(0, p)], 10, 0, 0, numElements=[5])
                s = gmsh.model.geo.extrude([l1[1]], 0, 4, 0, numElements=[2], recombine=True)
                gmsh.model.geo.extrude([s[1]], 0, 0, 4, numElements=[2], recombine=True)
                gmsh.model.geo.synchronize()
            gmsh.model.mesh.generate(3)
            msh = folder / f"{kind}.msh"
            gmsh.write(str(msh))
        finally:
            gmsh.finalize()
        m = meshio.read(msh)
        cells = [c for c in m.cells if c.type in ("tetra", "hexahedron")]
        clean = meshio.Mesh(m.points, cells)
        out[f"{kind}.msh"] = folder / f"{kind}.msh"
        for ext in (".inp", ".vtu", ".vtk"):
            path = folder / f"{kind}{ext}"
            if ext == ".vtk":
                meshio.write(path, clean, binary=False)
            else:
                meshio.write(path, clean)
            out[path.name] = path
        meshio.write(folder / f"{kind}_plain.msh", clean, file_format="gmsh22", binary=False)
        out[f"{kind}_plain.msh"] = folder / f"{kind}_plain.msh"
    return out


XML_DECK = """<ParameterList>
  <ParameterList name="Discretization">
    <Parameter name="Type" type="string" value="PdQuickGrid"/>
    <Parameter name="NeighborhoodType" type="string" value="Spherical"/>
    <ParameterList name="TensorProduct3DMeshGenerator">
      <Parameter name="Type" type="string" value="PdQuickGrid"/>
      <Parameter name="X Origin" type="double" value="0.0"/><Parameter name="Y Origin" type="double" value="0.0"/>
      <Parameter name="Z Origin" type="double" value="0.0"/><Parameter name="X Length" type="double" value="0.01"/>
      <Parameter name="Y Length" type="double" value="0.004"/><Parameter name="Z Length" type="double" value="0.004"/>
      <Parameter name="Number Points X" type="int" value="10"/><Parameter name="Number Points Y" type="int" value="4"/>
      <Parameter name="Number Points Z" type="int" value="4"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Materials"><ParameterList name="Steel">
    <Parameter name="Material Model" type="string" value="Elastic"/><Parameter name="Density" type="double" value="7800.0"/>
    <Parameter name="Young's Modulus" type="double" value="2.0e11"/><Parameter name="Poisson's Ratio" type="double" value="0.3"/>
  </ParameterList></ParameterList>
  <ParameterList name="Blocks"><ParameterList name="B">
    <Parameter name="Block Names" type="string" value="block_1"/><Parameter name="Material" type="string" value="Steel"/>
    <Parameter name="Horizon" type="double" value="0.003015"/>
  </ParameterList></ParameterList>
  <ParameterList name="Solver">
    <Parameter name="Initial Time" type="double" value="0.0"/><Parameter name="Final Time" type="double" value="2.0e-6"/>
    <ParameterList name="Verlet"><Parameter name="Safety Factor" type="double" value="0.8"/></ParameterList>
  </ParameterList>
</ParameterList>
"""


def copy_into(src: Path, dest: Path) -> None:
    for p in src.iterdir():
        if p.is_dir():
            shutil.copytree(p, dest / p.name)
        else:
            shutil.copy2(p, dest / p.name)
