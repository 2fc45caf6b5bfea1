"""core/discretization.py: Discretization.validate refuses repeated global ids whatever their
order (ascending ids are known unique without a sort)."""
import numpy as np
import pytest

from peridyn.core.discretization import Discretization


def points(gid):
    n = len(gid)
    return Discretization(x=np.zeros((n, 3)), volume=np.ones(n), block_id=np.ones(n, dtype=np.int64),
                          gid=np.asarray(gid, dtype=np.int64), block_names={1: "block_1"})


@pytest.mark.parametrize("gid", [[0, 1, 2, 3], [3, 0, 2, 1], [7], [], [0, 5, 9]])
def test_unique_ids_pass(gid):
    points(gid).validate()


@pytest.mark.parametrize("gid", [[0, 1, 1, 2], [2, 0, 2], [4, 4], [0, 1, 2, 0]])
def test_repeated_ids_are_refused_in_any_order(gid):
    with pytest.raises(ValueError, match="not unique"):
        points(gid).validate()
