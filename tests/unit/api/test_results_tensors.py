"""``peridyn.read`` puts components back together as the writer split them
(``peridyn.core.fields.component_names``): tensors (n, 3, 3), vectors (n, 3), scalars (n,), for
nodal, element and global variables and every frame; components stay readable by their names."""
from __future__ import annotations

import numpy as np
import pytest

import peridyn
from peridyn.core.fields import FieldSpec, Relation, component_names
from peridyn.io.exodus_reader import combine_components, component_groups
from peridyn.io.exodus_writer import ExodusBlock, ExodusWriter

N, FRAMES = 5, 3
RNG = np.random.default_rng(7)
STRESS = RNG.normal(size=(FRAMES, N, 3, 3))  # a full (non-symmetric) tensor: row-major XX XY XZ YX ...
STRAIN = RNG.normal(size=(FRAMES, N, 3, 3))
STRAIN = STRAIN + STRAIN.transpose(0, 1, 3, 2)  # symmetric, written by its six components
VELOCITY = RNG.normal(size=(FRAMES, N, 3))
MOMENTUM = RNG.normal(size=(FRAMES, 3))
GSTRESS = RNG.normal(size=(FRAMES, 3, 3))
DAMAGE = RNG.uniform(size=(FRAMES, N))
SYM = ["StrainXX", "StrainYY", "StrainZZ", "StrainXY", "StrainYZ", "StrainZX"]


def names(name: str, length: int, relation=Relation.ELEMENT) -> list[str]:
    return component_names(FieldSpec(name, relation, length))


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    path = tmp_path_factory.mktemp("tensors") / "t.e"
    stress, velocity = names("Cauchy_Stress", 9), names("Velocity", 3, Relation.NODE)
    gmom, gstress = names("Momentum_Sum", 3, Relation.GLOBAL), names("Stress_Sum", 9, Relation.GLOBAL)
    assert stress[:3] == ["Cauchy_StressXX", "Cauchy_StressXY", "Cauchy_StressXZ"]  # the writer's layout
    blocks = [ExodusBlock(1, "block_1", np.arange(3)), ExodusBlock(2, "block_2", np.arange(3, N))]
    with ExodusWriter(path, coords=RNG.normal(size=(N, 3)), node_num_map=np.arange(1, N + 1), blocks=blocks,
                      nodal_vars=velocity, element_vars=stress + SYM + ["Damage"], global_vars=gmom + gstress + ["Global_Kinetic_Energy"]) as w:
        for f in range(FRAMES):
            per_block = lambda v: [v[:3], v[3:]]  # noqa: E731
            element = {n: per_block(STRESS[f].reshape(N, 9)[:, k]) for k, n in enumerate(stress)}
            pick = {"StrainXX": (0, 0), "StrainYY": (1, 1), "StrainZZ": (2, 2), "StrainXY": (0, 1), "StrainYZ": (1, 2), "StrainZX": (2, 0)}
            element.update({n: per_block(STRAIN[f][:, i, j]) for n, (i, j) in pick.items()})
            element["Damage"] = per_block(DAMAGE[f])
            glob = {n: MOMENTUM[f, k] for k, n in enumerate(gmom)}
            glob.update({n: GSTRESS[f].reshape(9)[k] for k, n in enumerate(gstress)})
            glob["Global_Kinetic_Energy"] = 1.0
            w.write_step(float(f), nodal={n: VELOCITY[f][:, k] for k, n in enumerate(velocity)}, element=element, glob=glob)
    return peridyn.read(path)


def test_tensors_vectors_and_scalars_come_back_whole(result) -> None:
    assert set(result.fields) == {"Cauchy_Stress", "Strain", "Velocity", "Damage"}
    assert result["Cauchy_Stress"].shape == (FRAMES, N, 3, 3)
    np.testing.assert_array_equal(result["Cauchy_Stress"], STRESS)
    np.testing.assert_array_equal(result["Strain"], STRAIN)
    np.testing.assert_array_equal(result["Velocity"], VELOCITY)
    np.testing.assert_array_equal(result["Damage"], DAMAGE)
    for f in range(-FRAMES, FRAMES):
        np.testing.assert_array_equal(result.field("Cauchy_Stress", f), STRESS[f])
    assert not any(name.endswith(("X", "Y", "Z")) and name[:-1] in ("Cauchy_Stress", "Cauchy_StressX") for name in result.fields)


def test_global_vectors_and_tensors_and_components(result) -> None:
    np.testing.assert_array_equal(result["Momentum_Sum"], MOMENTUM)
    np.testing.assert_array_equal(result["Stress_Sum"], GSTRESS)
    assert result["Stress_Sum"].shape == (FRAMES, 3, 3) and result["Global_Kinetic_Energy"].shape == (FRAMES,)
    np.testing.assert_array_equal(result.globals["Momentum_SumY"], MOMENTUM[:, 1])
    np.testing.assert_array_equal(result["Cauchy_StressXY"], STRESS[:, :, 0, 1])  # components by name still work
    np.testing.assert_array_equal(result["VelocityZ"], VELOCITY[:, :, 2])
    np.testing.assert_array_equal(result["StrainZX"], STRAIN[:, :, 2, 0])


def test_bad_frames_are_named(result) -> None:
    from peridyn.api.checks import ArgumentError

    for frame in (FRAMES, -FRAMES - 1, 1.5):
        with pytest.raises(ArgumentError) as info:
            result.field("Damage", frame)
        assert info.value.path == ("Results.field", "frame")
    with pytest.raises(ArgumentError):
        result.frame_at(float("nan"))


@pytest.mark.parametrize("present, expected", [
    (["AX", "AY", "AZ"], {"A": "vector"}),
    (component_names(FieldSpec("S", Relation.ELEMENT, 9)), {"S": "tensor"}),
    (["SXX", "SYY", "SZZ", "SXY", "SYZ", "SXZ"], {"S": "symmetric"}),
    (["SXX", "SXY", "SXZ"], {"SX": "vector"}),  # only a vector can be read from these
    (["SXX", "SYY", "SZZ", "SXY", "SYZ"], {}),  # an incomplete tensor stays components
    (["BX", "BY"], {}),
    (component_names(FieldSpec("S", Relation.ELEMENT, 9)) + ["VX", "VY", "VZ"], {"S": "tensor", "V": "vector"}),
])
def test_component_groups(present, expected) -> None:
    groups = component_groups(present)
    assert {k: kind for k, (kind, _) in groups.items()} == expected
    for kind, comps in groups.values():
        values = {c: np.full(2, float(i)) for i, c in enumerate(comps)}
        assert combine_components(values, kind, comps).shape == ((2, 3) if kind == "vector" else (2, 3, 3))
