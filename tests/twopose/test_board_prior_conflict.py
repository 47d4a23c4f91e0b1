"""A board's measured placing sigma is a prior the sessions' data may contradict (issue
54; a new user's r5 F2): a 120-capture board's 352 dof outweighed sessions placing 1.5x
its sigma ("the data contradict ... taken 1x ... from 372 dof"; coverage 79%). Fisher's F
of the data's sigma0 against the board's multiplier on both dofs: where it rejects, the
board's sigma weighs as a guess and the trials set the placing sigma, said loudly."""

from __future__ import annotations

import math

import numpy as np

from twopose.uncertainty.misclosure import Misclosure
from twopose.uncertainty.noise import (
    TYPED_PRIOR_DOF,
    NoiseModel,
    PlacingSigma,
    VarianceFactor,
)
from twopose.uncertainty.noise_words import noise_words
from twopose.uncertainty.session_noise import noise_from

BOARD = PlacingSigma(sigma_in=0.104, sigma_sigma_in=0.104 / math.sqrt(2 * 352),
                     measured_by="board.mcap", captures=120)  # fmt: skip


def _misclosure(scale: float) -> Misclosure:
    """Four trials of 3 all-placing directions, their sigma0 squared ``scale``."""
    z = np.full((4, 3), math.sqrt(scale))
    return Misclosure(
        chi2=(z**2).sum(axis=1), dof=np.full(4, 3), placing_share=np.ones((4, 3)), z=z,
        bias=np.zeros((4, 1, 3, 3)), iterations=np.ones(4, dtype=np.int_),
    )  # fmt: skip


def test_data_that_contradict_the_board_make_it_give_way() -> None:
    model = NoiseModel(placing=BOARD)
    assert model.anchor().dof > 300
    checked = noise_from(_misclosure(2.5), model).noise
    assert checked is not None
    assert checked.anchor_contradicted < 0.01
    assert checked.anchor().dof == TYPED_PRIOR_DOF  # a guess now, not 352 dof
    assert "contradicted by the data" in checked.anchor().source


def test_data_that_agree_with_the_board_keep_it() -> None:
    model = NoiseModel(placing=BOARD)
    for scale in (0.5, 1.0, 1.5):  # 1.5 on 12 dof beside 352: p = 0.12
        checked = noise_from(_misclosure(scale), model).noise
        assert checked is model


def test_the_words_say_the_board_not_typed() -> None:
    factor = VarianceFactor(sigma0_sq=4.0, dof=12, placing_variance=3.5, variance_dof=20.0,
                            information=18.0, against="the board's sigma",
                            anchor_conflict=1e-5)  # fmt: skip
    said = noise_words(2.0, 12, math.nan, factor)
    assert "(they scatter more than the board's sigma)" in said
    assert "than typed" not in said
    assert (
        "the data contradict the board's placing sigma (F test, p < 0.01): regions likely" in said
    )
    typed = noise_words(2.0, 12)
    assert "(they scatter more than typed)" in typed
