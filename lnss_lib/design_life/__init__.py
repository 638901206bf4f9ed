"""The design life: does a constellation keep its geometry for years, and at what Delta-V?

One subject in three answers of rising cost, each module answering one question:

* :mod:`.screen` -- will a perilune reach the surface within the life? The doubly-averaged (secular) model
  of lunar J2 and the Earth's and Sun's quadrupole tides (:mod:`.secular`: ``SecularField``, Milankovitch
  equations on the e and j vectors, Moon-centred J2000) integrated from the initial states, with the tide's
  monthly terms restored to first order for the verdict (:mod:`.monthly_tide`): the campaign's stability
  screen, a tenth of a second per design over five years (compiled RK4); checked against
  the full model on random Table 3 designs by :mod:`lnss_lib.studies.screen_validation`.
* :mod:`.estimate` -- what would holding the geometry cost? The secular drift of mean e-vector, orbit
  normal, a and slot fitted on the evaluator's 10-day arc, priced with linearised GVE costs: the
  campaign's geometry-keeping Delta-V (``sk_dv_estimate_kms_per_year``).
* :mod:`.life_estimate` -- what would the service controller pay over the life? Safety raises where the averaged
  perilune (the screen's integration) would cross the floor (:mod:`.life_safety`), navigation restores where the
  constellation rebuilt from the averaged elements breaks the monitor's DOP rule (:mod:`.life_navigation`),
  relative node and slot held within the service's tolerances on the averaged evolution plus the 10-day arc
  (:mod:`.life_relative`): the operational campaign's estimate (``[sk_estimate] model = "life"``).
* :mod:`.closed_loop` -- what does flying the life cost? Every satellite (one :class:`.fleet.FleetState`)
  propagated with the full force model over the life, check by check, a controller
  (:mod:`.controllers`: the ``box`` or the ``service`` controller, or natural drift, which never burns)
  answering each check with burns; :mod:`.life_report` shapes the Dataset.
* :mod:`.evaluation` -- the verdict: the closed loop and the natural drift side by side, navigation over
  the life (south-pole DOP month by month, paper eq. 3-14), and the two cheap predictors above for the
  same design (``evaluate --design-life-days``).

So: screen -> estimate or life estimate (campaign, every design) -> closed loop -> evaluation (one design, minutes).
Under the closed loop:

* :mod:`.controllers` -- the controllers behind one protocol (``decide(t_tdb_s, fleet) -> list[Burn]``);
* :mod:`.fleet` -- the satellites' state, one chunk flown and one check measured, the burn queue;
* :mod:`.propagation` -- the chunked full-model propagation that flies impulsive burns, the life's force
  model, the insertion trim to the design's mean elements;
* :mod:`.mean_elements` -- one-orbit mean elements from vectors (no 1/e, no 1/sin i);
* :mod:`.control` -- the box controller's laws: drift-band slot control, overshoot targeting, tidal means;
* :mod:`.service` -- the service controller's decisions: safety (perilune predicted by :mod:`.screen`),
  navigation monitor, relative node and slot, where a burn went;
* :mod:`.tolerances` -- the relative node and slot tolerances of that controller, derived per design at the start
  of its life from how far one satellite may drift before its navigation requirement breaks;
* :mod:`.manoeuvres` -- impulses from the Gauss variational equations (paper eq. 25-29): the control-set
  GVE matrix and the one- or two-burn planner refined in two-body flight.

Beside them :mod:`.frozen` reads the averaged model of :mod:`.secular` in the Earth-Moon orbital plane
(``moon_op``): frozen and librating orbits.

Frames: states are Moon-centred J2000 (``_mci``); mean elements, boxes and the controllers work in the
profile's element frame (``[frames] element_frame``: the lunar equator of epoch, ``j2000`` or ``moon_op``;
:func:`lnss_lib.frames.element_frame_to_j2000`); burns are RTN. Settings: ``[stability]``
(screen), ``[sk_estimate]`` (estimate), ``[design_life]`` with ``.box`` and ``.service`` (closed loop),
``[life_evaluation]`` (evaluation), checked once at load (:mod:`lnss_lib.settings`): each function takes the
sections it reads and the :class:`lnss_lib.settings.Dynamics` bundle, numbers (a life that replaces the
section's is a number, ``life_days=``, or ``dataclasses.replace(section, life_days=...)``) and arrays; only
:func:`.evaluation.run_design_life` and :func:`.evaluation.evaluate_design_life`, which read most sections,
take the whole :class:`lnss_lib.settings.Settings` (the latter also an ``EvaluationContext``). Their presentation lives in :mod:`lnss_lib.studies.design_life`,
:mod:`lnss_lib.figures.design_life` and notebook 08. Nothing is re-exported here: import from the module.
"""
