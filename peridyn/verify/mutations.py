"""The catalogue of physics errors that ``peridyn verify`` must catch (:mod:`.mutation` puts each
into a copy of the package): per error, the substitution and the problems that measure it.

Each substitution names text in the package's source; when the source changes so that it no
longer matches, :func:`.mutation.apply` raises instead of reporting the error as missed."""
from __future__ import annotations

from .mutation import Mutation, Substitution as S

_EL = "materials/elastic.py"

MUTATIONS: tuple[Mutation, ...] = (
    Mutation(
        "lps-dilatation-2.9", "the LPS dilatation factor 3 -> 2.9 in every dilatation kernel of `Elastic`",
        (S(_EL, "return ((((3.0 * w) * keep) * z) * e) * volume[j]", "return ((((2.9 * w) * keep) * z) * e) * volume[j]"),
         S(_EL, "return ((3.0 * z) * (L - z)) * P[j, 5]", "return ((2.9 * z) * (L - z)) * P[j, 5]"),
         S(_EL, "return ((((3.0 * w) * (1.0 - d)) * z) * (L - z)) * P[j, 5]", "return ((((2.9 * w) * (1.0 - d)) * z) * (L - z)) * P[j, 5]")),
        ("wave-speed", "dispersion", "lattice-constants", "poisson-ratio", "static-modulus", "confined-compression", "manufactured-lps",
         "lame-sphere"),
    ),
    Mutation(
        "block-density-x0.9", "every block after the first given 0.9 times its density in the points' masses",
        (S("engine/simulation.py", "densities = np.array([blk.density for blk in self.blocks])",
           "densities = np.array([blk.density * (1.0 if b == 0 else 0.9) for b, blk in enumerate(self.blocks)])"),),
        ("density-contrast",), area="solvers",
    ),
    Mutation(
        "critical-step-x1.7", "the critical time-step estimate 1.7 times too large",
        (S("engine/critical_step.py", "    return dt[: sim.num_owned]\n", "    return 1.7 * dt[: sim.num_owned]\n"),),
        ("stability",), area="time step",
    ),
    Mutation(
        "critical-step-x0.6", "the critical time-step estimate 0.6 times too small",
        (S("engine/critical_step.py", "    return dt[: sim.num_owned]\n", "    return 0.6 * dt[: sim.num_owned]\n"),),
        ("stability",), area="time step",
    ),
    Mutation(
        "verlet-kick-x1.1", "velocity Verlet's first half kick 10 % too large",
        (S("solvers/explicit/laws.py", "        v[i, c] += dt2 * a[i, c]\n", "        v[i, c] += (1.1 * dt2) * a[i, c]\n"),),
        ("verlet-energy",), area="solvers",
    ),
    Mutation(
        "lps-shear-x0.95", "the LPS deviatoric coefficient 15 mu / m 5 % too small (`Elastic`)",
        (S(_EL, "    a = (15.0 * mu) / m\n", "    a = (14.25 * mu) / m\n"),),
        ("wave-speed", "dispersion", "lattice-constants", "poisson-ratio", "static-modulus", "manufactured-lps", "one-layer-plate"),
    ),
    Mutation(
        "lps-bulk-x1.05", "the LPS bulk term 3 K / m 5 % too large (`Elastic`)",
        (S(_EL, "return a, theta * ((3.0 * K) / m - a / 3.0)", "return a, theta * ((3.15 * K) / m - a / 3.0)"),),
        ("wave-speed", "dispersion", "lattice-constants", "poisson-ratio", "static-modulus", "manufactured-lps"),
    ),
    Mutation(
        "bond-based-micromodulus-x1.05", "the 3D bond-based micromodulus 18 K / (pi delta^4) 5 % too large",
        (S("materials/elastic_bond_based.py", "self.c = (18.0 * self.K)", "self.c = (18.9 * self.K)"),),
        ("force-convergence", "wave-speed", "dispersion", "lattice-constants", "poisson-ratio"),
    ),
    Mutation(
        "bond-based-2d-micromodulus-x1.05", "the 2D bond-based micromodulus 12 K / (pi h delta^3) 5 % too large",
        (S("materials/elastic_bond_based.py", "self.c = (12.0 * self.K)", "self.c = (12.6 * self.K)"),),
        ("lattice-constants", "j-integral", "kalthoff-winkler", "griffith", "one-layer-plate"),
    ),
    Mutation(
        "correspondence-shear-x1.1", "the correspondence elastic stress with G 10 % too large",
        (S("materials/correspondence/stress.py", "store9(sigma_NP1, i, _trial_stress(load9(sigma_N, i), de, dth, K, G))",
           "store9(sigma_NP1, i, _trial_stress(load9(sigma_N, i), de, dth, K, 1.1 * G))"),),
        ("poisson-ratio", "static-modulus", "kirsch", "lame-cylinder"),
    ),
    Mutation(
        "correspondence-bulk-x1.05", "the correspondence elastic stress with K 5 % too large",
        (S("materials/correspondence/stress.py", "store9(sigma_NP1, i, _trial_stress(load9(sigma_N, i), de, dth, K, G))",
           "store9(sigma_NP1, i, _trial_stress(load9(sigma_N, i), de, dth, 1.05 * K, G))"),),
        ("lame-cylinder", "lame-sphere"),
    ),
    Mutation(
        "plastic-yield-x1.1", "the yield stress of `Elastic Plastic` 10 % too large",
        (S("materials/elastic_plastic.py", "return yield_value(params.yield_stress, horizon,", "return yield_value(1.1 * params.yield_stress, horizon,"),),
        ("plasticity-uniaxial",),
    ),
    Mutation(
        "viscoelastic-tau-x1.1", "the viscoelastic relaxation time tau_b 10 % too large",
        (S("materials/viscoelastic.py", "return relaxation_constants(float(self.params.tau_b), float(block.time_step))",
           "return relaxation_constants(1.1 * float(self.params.tau_b), float(block.time_step))"),),
        ("viscoelastic-relaxation",),
    ),
    Mutation(
        "diffusion-coefficient-x1.05", "the diffusivity of `Diffusion` 5 % too large",
        (S("materials/diffusion.py", "self.kappa = float(params.coefficient)", "self.kappa = 1.05 * float(params.coefficient)"),),
        ("diffusion",),
    ),
    Mutation(
        "critical-stretch-x1.1", "the Critical Stretch damage model breaking bonds at 1.1 s_c",
        (S("damage/critical_stretch.py", "return float(self.params.critical_stretch)",
           "return 1.1 * float(self.params.critical_stretch)"),),
        ("critical-stretch", "brazilian-disk", "griffith", "j-integral", "kalthoff-winkler", "glass-branching"), area="damage",
    ),
    Mutation(
        "short-range-contact-x1.1", "the short-range force contact's force 9 k / (pi delta^4) per visit 10 % too large",
        (S("contact/short_range.py", "c = (9.0 * k) / ((((PI * delta) * delta) * delta) * delta)",
           "c = (9.9 * k) / ((((PI * delta) * delta) * delta) * delta)"),),
        ("hertz", "contact-step"), area="contact",
    ),
    Mutation(
        "contact-step-stiffness-x1.1", "the short-range contact's pair stiffness 18 k / (pi delta^5) in the stable-step estimate 10 % too large",
        (S("contact/short_range.py", "return (18.0 * self.params.spring_constant)", "return (19.8 * self.params.spring_constant)"),),
        ("contact-step", "contact-stability"), area="time step",
    ),
    Mutation(
        "penalty-contact-x1.1", "the penalty contact's constant 9 / pi 10 % too large",
        (S("contact/penalty.py", "HALF_PENALTY = 4.5 / math.pi", "HALF_PENALTY = 4.95 / math.pi"),),
        ("hertz-penalty",), area="contact",
    ),
    Mutation(
        "verlet-drift-x1.01", "velocity Verlet's drift du = dt v 1 % too long",
        (S("solvers/explicit/laws.py", "        d = dt * v[i, c]\n", "        d = (1.01 * dt) * v[i, c]\n"),),
        ("verlet-energy",), area="solvers",
    ),
    Mutation(
        "neo-hookean-linearised", "the neo-Hookean stress law's B = F F^T linearised to F + F^T - I (the same to first order in "
        "the strain, not objective)",
        (S("materials/correspondence/laws.py", "    B = F_new @ F_new.T\n", "    B = F_new + F_new.T - np.eye(3)\n"),),
        ("rigid-rotation",),
    ),
    Mutation(
        "newmark-beta-x1.2", "Newmark's beta 1.2 times the deck's (0.3 for 1/4)",
        (S("solvers/implicit/newmark.py", "beta, gamma = ip.beta, ip.gamma", "beta, gamma = 1.2 * ip.beta, ip.gamma"),),
        ("newmark-energy",), area="solvers",
    ),
)

#: the mutations ``tests/verification/test_mutations.py`` runs in CI (the issue's three)
CI: tuple[str, ...] = ("lps-dilatation-2.9", "critical-step-x1.7", "verlet-kick-x1.1")

#: name -> mutation
BY_NAME: dict[str, Mutation] = {m.name: m for m in MUTATIONS}
