"""The setup: what is asked and checked before anything is recorded.

The setup's rules (``rules``) and its form (``form``), plan files read and checked
(``plan_file``) and recorded unattended (``plan``), and a continuation's setup taken from
the session it continues (``continuation``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from recorder.setup.continuation import Continued, read_continued
    from recorder.setup.form import (
        SETUP_FIELDS,
        FormRefusedError,
        form_fields,
        parse_pose_form,
        setup_from_answers,
    )
    from recorder.setup.plan import record_plan
    from recorder.setup.plan_file import Plan, continued_plan, load_plan
    from recorder.setup.rules import (
        PLANE_OFFSET_KEY,
        GuidanceAsked,
        PoseTyping,
        Setup,
        board_corner,
        board_refusal,
        check_rig,
        check_rig_early,
        default_principal,
        distinct_point,
        inherited_words,
        inner_corners,
        number_pair,
        off_plane,
        parse_vector,
        plane_offsets_given,
        plane_option,
        reader,
        refuse_other_planes,
        target_precision,
        with_guidance,
    )

__all__ = [
    "PLANE_OFFSET_KEY",
    "SETUP_FIELDS",
    "Continued",
    "FormRefusedError",
    "GuidanceAsked",
    "Plan",
    "PoseTyping",
    "Setup",
    "board_corner",
    "board_refusal",
    "check_rig",
    "check_rig_early",
    "continued_plan",
    "default_principal",
    "distinct_point",
    "form_fields",
    "inherited_words",
    "inner_corners",
    "load_plan",
    "number_pair",
    "off_plane",
    "parse_pose_form",
    "parse_vector",
    "plane_offsets_given",
    "plane_option",
    "read_continued",
    "reader",
    "record_plan",
    "refuse_other_planes",
    "setup_from_answers",
    "target_precision",
    "with_guidance",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "PLANE_OFFSET_KEY": "recorder.setup.rules",
    "SETUP_FIELDS": "recorder.setup.form",
    "Continued": "recorder.setup.continuation",
    "FormRefusedError": "recorder.setup.form",
    "GuidanceAsked": "recorder.setup.rules",
    "Plan": "recorder.setup.plan_file",
    "PoseTyping": "recorder.setup.rules",
    "Setup": "recorder.setup.rules",
    "board_corner": "recorder.setup.rules",
    "board_refusal": "recorder.setup.rules",
    "check_rig": "recorder.setup.rules",
    "check_rig_early": "recorder.setup.rules",
    "continued_plan": "recorder.setup.plan_file",
    "default_principal": "recorder.setup.rules",
    "distinct_point": "recorder.setup.rules",
    "form_fields": "recorder.setup.form",
    "inherited_words": "recorder.setup.rules",
    "inner_corners": "recorder.setup.rules",
    "load_plan": "recorder.setup.plan_file",
    "number_pair": "recorder.setup.rules",
    "off_plane": "recorder.setup.rules",
    "parse_pose_form": "recorder.setup.form",
    "parse_vector": "recorder.setup.rules",
    "plane_offsets_given": "recorder.setup.rules",
    "plane_option": "recorder.setup.rules",
    "read_continued": "recorder.setup.continuation",
    "reader": "recorder.setup.rules",
    "record_plan": "recorder.setup.plan",
    "refuse_other_planes": "recorder.setup.rules",
    "setup_from_answers": "recorder.setup.form",
    "target_precision": "recorder.setup.rules",
    "with_guidance": "recorder.setup.rules",
}

__getattr__, __dir__ = lazy_exports("recorder.setup", _HOMES, __all__)
