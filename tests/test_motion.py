from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from seedtrack.tracking.goa import GOAConfig, goa
from seedtrack.tracking.motion import (
    INDIVIDUAL_MODELS,
    CombinedModel,
    GeneralisedMean,
    IndividualModel,
    NearestNeighbour,
    SmoothMotion,
    smooth_motion_cost,
    smooth_motion_speed_ratio_limit,
)


def test_im2_is_zero_for_unchanged_motion_and_grows_with_turning():
    v0 = np.array([[3.0, 0.0]] * 3)
    v1 = np.array([[3.0, 0.0], [0.0, 3.0], [-3.0, 0.0]])
    cost = smooth_motion_cost(v0, v1, 0.1, 0.9)
    assert cost[0] == pytest.approx(0.0, abs=1e-9)
    assert cost[1] == pytest.approx(0.1)
    assert cost[2] == pytest.approx(0.2)


def test_im2_speed_term():
    cost = smooth_motion_cost(np.array([[1.0, 0.0]]), np.array([[4.0, 0.0]]), 0.0, 1.0)
    assert cost[0] == pytest.approx(1 - 2 * 2 / 5, rel=1e-3)


def test_im2_zero_vectors_are_defined():
    cost = smooth_motion_cost(np.zeros((1, 2)), np.zeros((1, 2)), 0.1, 0.9)
    assert cost[0] == pytest.approx(0.0)
    cost = smooth_motion_cost(np.zeros((1, 2)), np.array([[5.0, 0.0]]), 0.1, 0.9)
    assert cost[0] == pytest.approx(0.9, abs=0.05)


@pytest.mark.parametrize("phi_max", [0.05, 0.1, 0.3])
def test_speed_ratio_limit_is_where_the_speed_term_reaches_phi(phi_max):
    ratio = smooth_motion_speed_ratio_limit(phi_max, 0.9)
    cost = smooth_motion_cost(np.array([[10.0, 0.0]]), np.array([[10.0 * ratio, 0.0]]), 0.1, 0.9)
    assert cost[0] == pytest.approx(phi_max, rel=1e-3)


def test_unbounded_speed_ratio_when_phi_exceeds_the_weight():
    assert smooth_motion_speed_ratio_limit(1.0, 0.9) == np.inf


def test_cm1_exponent_and_cm2_reduces_to_cm1():
    cost = np.array([0.02, 0.05, 0.08])
    head = np.array([0, 0, 1])
    measurement = np.array([0, 1, 1])
    np.testing.assert_allclose(CombinedModel("cm1", z=2).weights(cost, head, measurement), cost**2)
    np.testing.assert_allclose(CombinedModel("cm2", w1=0, w2=0).weights(cost, head, measurement), cost)
    cm2 = CombinedModel("cm2", w1=0.5, w2=0.5).weights(cost, head, measurement)
    # Pair (0, 0): alternative of head 0 costs 0.05, no competitor for measurement 0.
    assert cm2[0] == pytest.approx(0.02 - 0.5 * 0.05)


def test_model_names_are_checked():
    with pytest.raises(ValueError, match="individual model"):
        IndividualModel("im9")
    with pytest.raises(ValueError, match="combined model"):
        CombinedModel("cm3")


def test_a_model_is_built_by_its_registered_name_and_a_new_one_needs_only_a_subclass():
    assert IndividualModel("im1", power=2) == NearestNeighbour(power=2)
    assert isinstance(IndividualModel(), SmoothMotion) and isinstance(CombinedModel(), GeneralisedMean)
    with pytest.raises(ValueError, match="im1"):
        NearestNeighbour(name="im2")

    @dataclass(frozen=True)
    class Still(IndividualModel, key="still"):
        """Cost = distance in pixels, whatever the scale."""

        name: str = "still"
        order: ClassVar[int] = 1

        def cost(self, candidates, phi_max, d_max):
            return np.hypot(*candidates.velocity.T)

    try:
        assert "still" in INDIVIDUAL_MODELS
        frames = [np.array([[0.0, 0.0], [10.0, 0.0]]), np.array([[0.05, 0.0], [10.0, 0.05]]), np.array([[0.25, 0.0], [10.0, 0.1]])]
        # Steps of 0.2 px and 0.05 px: IM1 against d_max 1 takes both, this model only the
        # second (phi_max is 0.1 px here).
        given = np.array([[0, 0], [1, 1]])
        assert goa(frames, given, GOAConfig(individual=IndividualModel("im1"), d_max=1.0)).measurement[:, 2].tolist() == [0, 1]
        assert goa(frames, given, GOAConfig(individual=IndividualModel("still"), d_max=1.0)).measurement[:, 2].tolist() == [-1, 1]
    finally:
        del INDIVIDUAL_MODELS["still"]
