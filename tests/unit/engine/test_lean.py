"""A run allocates and computes only what its deck uses."""
import json
import subprocess
import sys
import textwrap

from peridyn.testing import build_simulation, cube_deck

ELASTIC = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 1e9}


def test_no_bond_damage_array_without_a_damage_model():
    sim = build_simulation(cube_deck(ELASTIC, n=3))
    assert "Bond_Damage" not in sim.fields and "Damage" not in sim.fields
    damaged = build_simulation(cube_deck(ELASTIC, n=3, damage={"Damage Model": "Critical Stretch", "Critical Stretch": 0.1}))
    assert damaged.fields["Bond_Damage"].shape == (damaged.bonds.num_bonds,)


def test_outputs_nobody_asked_for_are_not_allocated():
    sim = build_simulation(cube_deck(ELASTIC, n=3))
    assert sim.contact is None and "Contact_Force_Density" not in sim.fields  # no contact arrays without Contact
    for name in ("Kinetic_Energy", "Acceleration", "Force", "External_Force_Density", "Temperature", "Horizon", "Deformation_Gradient"):
        assert name not in sim.fields, name
    extra = {"Output": {"Output Filename": "o", "Output Frequency": 1, "Output Variables": {"Kinetic_Energy": True}}}
    asked = build_simulation(cube_deck(ELASTIC, n=3, extra=extra))
    assert "Kinetic_Energy" in asked.fields and "Acceleration" not in asked.fields


def test_serial_run_imports_neither_mpi_nor_contact_nor_gpu_code(tmp_path):
    deck = tmp_path / "d.yaml"
    tree = cube_deck(ELASTIC, n=3)
    tree["Solver"] = {"Final Time": 5e-3, "Verlet": {"Safety Factor": 0.5}}
    tree["Output"] = {"Output Filename": "o", "Output Frequency": 1, "Output Variables": {"Displacement": True}}
    from peridyn.deck.files import dump_yaml

    deck.write_text(dump_yaml(tree))
    script = textwrap.dedent(
        f"""
        import json, sys
        from peridyn.cli import main
        code = main(["run", {str(deck)!r}, "-q", "--output-dir", {str(tmp_path)!r}])
        mods = [m for m in sys.modules if m.startswith(("mpi4py", "peridyn.contact", "peridyn.gpu", "peridyn.kernels.numba_cuda", "numba.cuda", "numba_cuda"))]
        print(json.dumps({{"code": code, "mods": mods}}))
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path)
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result == {"code": 0, "mods": []}, proc.stderr
