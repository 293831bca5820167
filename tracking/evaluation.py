"""Every score of a track set against the truth, in one record: the paper's measures
(:mod:`seedtrack.tracking.metrics`), the CLEAR-MOT and identity measures
(:mod:`seedtrack.tracking.clear_mot`), HOTA (:mod:`seedtrack.tracking.hota`) and the ISBI 2012
particle tracking challenge's (:mod:`seedtrack.tracking.particle_challenge`), as
``seedtrack evaluate`` prints them."""

from __future__ import annotations

from dataclasses import dataclass

from .clear_mot import ClearMotScores, clear_mot
from .hota import hota
from .metrics import score_tracks
from .particle_challenge import challenge_scores
from .tracks import Tracks


@dataclass(frozen=True)
class Scores:
    """How well a result matches the truth; rates in [0, 1] (NaN when undefined), distances in pixels.

    Attributes
    ----------
    tolerance_px : float
        Matching distance.
    true_tracks, result_tracks, correct_tracks : int
        Tracks in the truth and in the result; true tracks followed without error throughout.
    track_error : float
        The paper's strict track error: share of true tracks not followed correctly.
    relaxed_correct : int
    relaxed_merit : float
        The paper's relaxed trajectory merit (1 - relaxed error).
    true_links, correct_links : int
    link_error : float
        Share of true links (consecutive true points) that no result track makes.
    true_points, result_points, misses, false_positives, id_switches, fragmentations : int
        CLEAR-MOT counts.
    mota : float
    motp_px : float
        Mean distance of the matched points.
    idf1, idp, idr : float
        Identity F1, precision and recall.
    hota, det_a, ass_a, loc_a : float
        HOTA and its detection, association and localisation accuracies, with the point
        similarity ``max(0, 1 - distance / tolerance)``.
    isbi_alpha, isbi_beta, isbi_jsc, isbi_jsc_theta : float
        The ISBI 2012 particle tracking challenge's track-pairing measures, gate = tolerance.
    isbi_rmse_px : float
        Their root mean square distance of the matched points.
    """

    tolerance_px: float
    true_tracks: int
    result_tracks: int
    correct_tracks: int
    track_error: float
    relaxed_correct: int
    relaxed_merit: float
    true_links: int
    correct_links: int
    link_error: float
    true_points: int
    result_points: int
    misses: int
    false_positives: int
    id_switches: int
    fragmentations: int
    mota: float
    motp_px: float
    idf1: float
    idp: float
    idr: float
    hota: float
    det_a: float
    ass_a: float
    loc_a: float
    isbi_alpha: float
    isbi_beta: float
    isbi_jsc: float
    isbi_jsc_theta: float
    isbi_rmse_px: float


def evaluate_tracks(result: Tracks, truth: Tracks, tolerance: float = 3.0) -> tuple[Scores, ClearMotScores]:
    """Score ``result`` against ``truth``, points matched one to one within ``tolerance`` pixels.

    Returns
    -------
    scores : Scores
    clear : ClearMotScores
        With the per-frame counts.

    Examples
    --------
    >>> import numpy as np
    >>> from seedtrack.tracking.tracks import Tracks
    >>> truth = Tracks.from_rows([0, 0, 0], [0, 1, 2], [0.0, 1.0, 2.0], [5.0, 5.0, 5.0])
    >>> scores, _ = evaluate_tracks(truth, truth)
    >>> scores.correct_tracks, scores.link_error, scores.idf1
    (1, 0.0, 1.0)
    """
    paper = score_tracks(result, truth, tolerance)
    clear = clear_mot(result, truth, tolerance)
    higher = hota(result, truth, tolerance)
    challenge = challenge_scores(result, truth, tolerance)
    scores = Scores(
        tolerance_px=tolerance,
        true_tracks=paper.true_tracks,
        result_tracks=result.n_tracks,
        correct_tracks=paper.correct_tracks,
        track_error=paper.track_error,
        relaxed_correct=paper.relaxed_correct,
        relaxed_merit=1.0 - paper.relaxed_error,
        true_links=paper.true_links,
        correct_links=paper.correct_links,
        link_error=paper.link_error,
        true_points=clear.num_objects,
        result_points=clear.num_predictions,
        misses=clear.num_misses,
        false_positives=clear.num_false_positives,
        id_switches=clear.num_switches,
        fragmentations=clear.num_fragmentations,
        mota=clear.mota,
        motp_px=clear.motp,
        idf1=clear.idf1,
        idp=clear.idp,
        idr=clear.idr,
        hota=higher.hota,
        det_a=higher.det_a,
        ass_a=higher.ass_a,
        loc_a=higher.loc_a,
        isbi_alpha=challenge.alpha,
        isbi_beta=challenge.beta,
        isbi_jsc=challenge.jsc,
        isbi_jsc_theta=challenge.jsc_theta,
        isbi_rmse_px=challenge.rmse,
    )
    return scores, clear


__all__ = ["Scores", "evaluate_tracks"]
