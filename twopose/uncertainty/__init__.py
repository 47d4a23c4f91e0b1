"""The uncertainty: each estimate's region and the noise it assumes.

Propagation (first order, and the second-order term where the estimate bends), NEES and
the dominant input (``propagate``), the noise every region
assumes and its words (``noise``), each trial's misclosure (``misclosure``), the placing
variance's multiplier (``placing_variance``), the trials kept out of its pool
(``robust_flags``), the operator's other sessions as its prior (``operator_pool``), the
trials flagged before pooling (``blunders``: by their misclosure, against the other trials
of one target, against their own truth) and a session's noise as the estimation settles
it (``session_noise``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.uncertainty.blunders import EXPLAINS_LEVEL, TrialTests
    from twopose.uncertainty.misclosure import PLANES, RAYS, Misclosure, MisclosureModel
    from twopose.uncertainty.noise import (
        FACTOR_TEST_LEVEL,
        MIN_PLACING_DOF,
        TYPED_PRIOR_DOF,
        NoiseModel,
        PlacingPrior,
        PlacingSigma,
        VarianceFactor,
    )
    from twopose.uncertainty.noise_words import noise_words
    from twopose.uncertainty.operator_pool import SessionNoise, operator_priors
    from twopose.uncertainty.propagate import (
        CHI2_95,
        INPUTS_PER_VIEW,
        PLACING,
        SHARED_INPUTS,
        Propagated,
        Shared,
        chi2_95,
        dominant_input,
        enough_frames,
        frame_scatter,
        measurement_covariance,
        nees,
        pooled_scatter,
        region_dof,
        semiaxis95,
        uncertainty_columns,
    )
    from twopose.uncertainty.robust_flags import BAARDA_LEVEL
    from twopose.uncertainty.session_noise import (
        noise_of,
        operator_group,
        placed,
        placing_sigma,
        placing_sigmas,
        placing_source,
        region_multipliers,
        session_statistics,
    )

__all__ = [
    "BAARDA_LEVEL",
    "CHI2_95",
    "EXPLAINS_LEVEL",
    "FACTOR_TEST_LEVEL",
    "INPUTS_PER_VIEW",
    "MIN_PLACING_DOF",
    "PLACING",
    "PLANES",
    "RAYS",
    "SHARED_INPUTS",
    "TYPED_PRIOR_DOF",
    "Misclosure",
    "MisclosureModel",
    "NoiseModel",
    "PlacingPrior",
    "PlacingSigma",
    "Propagated",
    "SessionNoise",
    "Shared",
    "TrialTests",
    "VarianceFactor",
    "chi2_95",
    "dominant_input",
    "enough_frames",
    "frame_scatter",
    "measurement_covariance",
    "nees",
    "noise_of",
    "noise_words",
    "operator_group",
    "operator_priors",
    "placed",
    "placing_sigma",
    "placing_sigmas",
    "placing_source",
    "pooled_scatter",
    "region_dof",
    "region_multipliers",
    "semiaxis95",
    "session_statistics",
    "uncertainty_columns",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "BAARDA_LEVEL": "twopose.uncertainty.robust_flags",
    "CHI2_95": "twopose.uncertainty.propagate",
    "EXPLAINS_LEVEL": "twopose.uncertainty.blunders",
    "FACTOR_TEST_LEVEL": "twopose.uncertainty.noise",
    "INPUTS_PER_VIEW": "twopose.uncertainty.propagate",
    "MIN_PLACING_DOF": "twopose.uncertainty.noise",
    "PLACING": "twopose.uncertainty.propagate",
    "PLANES": "twopose.uncertainty.misclosure",
    "RAYS": "twopose.uncertainty.misclosure",
    "SHARED_INPUTS": "twopose.uncertainty.propagate",
    "TYPED_PRIOR_DOF": "twopose.uncertainty.noise",
    "Misclosure": "twopose.uncertainty.misclosure",
    "MisclosureModel": "twopose.uncertainty.misclosure",
    "NoiseModel": "twopose.uncertainty.noise",
    "PlacingPrior": "twopose.uncertainty.noise",
    "PlacingSigma": "twopose.uncertainty.noise",
    "Propagated": "twopose.uncertainty.propagate",
    "SessionNoise": "twopose.uncertainty.operator_pool",
    "Shared": "twopose.uncertainty.propagate",
    "TrialTests": "twopose.uncertainty.blunders",
    "VarianceFactor": "twopose.uncertainty.noise",
    "chi2_95": "twopose.uncertainty.propagate",
    "dominant_input": "twopose.uncertainty.propagate",
    "enough_frames": "twopose.uncertainty.propagate",
    "frame_scatter": "twopose.uncertainty.propagate",
    "measurement_covariance": "twopose.uncertainty.propagate",
    "nees": "twopose.uncertainty.propagate",
    "noise_of": "twopose.uncertainty.session_noise",
    "noise_words": "twopose.uncertainty.noise_words",
    "operator_group": "twopose.uncertainty.session_noise",
    "operator_priors": "twopose.uncertainty.operator_pool",
    "placed": "twopose.uncertainty.session_noise",
    "placing_sigma": "twopose.uncertainty.session_noise",
    "placing_sigmas": "twopose.uncertainty.session_noise",
    "placing_source": "twopose.uncertainty.session_noise",
    "pooled_scatter": "twopose.uncertainty.propagate",
    "region_dof": "twopose.uncertainty.propagate",
    "region_multipliers": "twopose.uncertainty.session_noise",
    "semiaxis95": "twopose.uncertainty.propagate",
    "session_statistics": "twopose.uncertainty.session_noise",
    "uncertainty_columns": "twopose.uncertainty.propagate",
}

__getattr__, __dir__ = lazy_exports("twopose.uncertainty", _HOMES, __all__)
