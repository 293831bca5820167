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
    np.testing.assert_allclose(CombinedModel("cm1", z=2).weights(cost, head, measurement, 0.1), cost**2)
    np.testing.assert_allclose(CombinedModel("cm2", w1=0, w2=0).weights(cost, head, measurement, 0.1), cost)
    cm2 = CombinedModel("cm2", w1=0.5, w2=0.5).weights(cost, head, measurement, 0.1)
    # Pair (0, 0): alternative of head 0 costs 0.05, no competitor for measurement 0.
    assert cm2[0] == pytest.approx(0.02 - 0.5 * 0.05)


def test_cm2_margin_rewards_only_each_heads_and_measurements_favourite():
    cost = np.array([0.02, 0.05, 0.08, 0.03, 0.03])
    head = np.array([0, 0, 1, 2, 2])
    measurement = np.array([0, 1, 1, 2, 3])
    model = CombinedModel("cm2-margin", w1=1.0, w2=0.0)
    # Head 0's favourite beats its other option by 0.03; head 1's lone pair beats its slave
    # (phi_max 0.1) by 0.02; head 2's two equal pairs beat nothing.
    np.testing.assert_allclose(model.weights(cost, head, measurement, 0.1), [-0.01, 0.05, 0.06, 0.03, 0.03])
    # Measurement 1's favourite is head 0 (0.05 against 0.08): it gains w2 times 0.03.
    np.testing.assert_allclose(CombinedModel("cm2-margin", w1=0.0, w2=1.0).weights(cost, head, measurement, 0.1),
                               [-0.06, 0.02, 0.08, -0.04, -0.04])
    np.testing.assert_allclose(CombinedModel("cm2-margin").weights(cost, head, measurement, 0.1), cost)


def test_cm2_margin_can_change_the_optimum_where_cm2_as_written_cannot():
    # Three heads and three measurements, every pair gated. CM1's optimum (costs 0.038 + 0.059 +
    # 0.049) stays CM2-as-written's for any weights; the margin form rewards head 0's clear
    # favourite (0.027, next 0.038) and measurement 2's (head 0) and takes 0.027 + 0.074 + 0.049.
    from scipy.optimize import linear_sum_assignment

    matrix = np.array([[0.039, 0.027, 0.038], [0.066, 0.059, 0.074], [0.049, 0.088, 0.063]])
    head, measurement = (index.ravel() for index in np.indices(matrix.shape))

    def best(name, **weights):
        weight = np.zeros(matrix.shape)
        weight[head, measurement] = CombinedModel(name, **weights).weights(matrix.ravel(), head, measurement, 0.1)
        return tuple(int(j) for j in linear_sum_assignment(weight)[1])

    assert best("cm1") == (2, 1, 0)
    assert best("cm2", w1=0.9, w2=0.9) == best("cm2", w1=0.1, w2=0.5) == (2, 1, 0)
    assert best("cm2-margin", w1=0.5, w2=0.5) == (1, 2, 0)


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
