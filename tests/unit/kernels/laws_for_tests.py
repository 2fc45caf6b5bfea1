"""Loop laws used by the kernel-layer tests (module level: a law's functions must be importable)."""
import math

from peridyn.core.traversal import BondMap, PairForce, PointSum


def half(x):
    return 0.5 * x


def sum_term(i, j, b, ex, ey, ez, L, z, p, args):
    w, = args[:1]
    return half(w[j] * (L - z)) + p


def owner(i, args):
    return args[1][i]


def scale(i, acc, p, args):
    return acc * args[2]


def skip_marked(i, b, p, args):
    return args[3][b] == 0


def bond_stretch(i, j, b, ex, ey, ez, L, z, p, args):
    return (L - z) / z


def pair(i, j, b, ex, ey, ez, L, z, p, args):
    return math.exp(-z) * (L - z) * args[0][j]


SUM = PointSum(sum_term, point=owner, finish=scale, gate=skip_marked)
STRETCH = BondMap(bond_stretch)
PAIR = PairForce(pair, gate=skip_marked)


def moment_term(i, j, b, ex, ey, ez, L, z, p, args):
    return (ex * args[0][j], ey * args[0][j], ez * args[0][j])


def normalized(i, acc, p, args):
    return (acc[0] / args[1], acc[1] / args[1], acc[2] / args[1])


def unit_bond(i, j, b, ex, ey, ez, L, z, p, args):
    return (ex / L, ey / L, ez / L)


MOMENT = PointSum(moment_term, finish=normalized, width=3)
UNIT = BondMap(unit_bond, width=3)
