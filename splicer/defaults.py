"""Default settings of the alignment, in one place.

:class:`splicer.options.SpliceOptions`, the passes in :mod:`splicer.align` and the feature
functions in :mod:`splicer.metrics` all take their defaults from here, so a notebook that
calls ``phase_features(markers)`` sees the same dead zone as the splice.  The values were
chosen by measurement on held-out synthetic separations (README *Accuracy*; benchmarks/HISTORY.md).

Units are in the names: ``_S`` seconds, ``_FPS`` frames per second, ``_FRAMES`` frames.
"""

from __future__ import annotations

#: Pass-1 band width: 30 % of the body take (the paper).  See :func:`splicer.band.band_frames`.
#: Used for takes aligned end to end without the coarse guide (up to :data:`COARSE_ABOVE_S`).
BAND1 = "30%"
#: Pass-1 band width of a guided long take (fixed ends, longer than :data:`COARSE_ABOVE_S`):
#: the band follows the coarse guide pass's path, so it only has to hold the fine path's
#: departures from that path, not the take's drift from uniform timing.  30 % of a 20-minute
#: take (about 2 billion band cells, 2 GB of DTW steps) would be absurd.  Measured on the
#: 20-minute benchmark pair (README *Speed*; benchmarks/HISTORY.md): bands of 4, 8 and 20 s give the same pass-1 path
#: and confidence; 2 s moves the path (left side mean error 5.4 -> 6.7 frames); chosen with a
#: margin over that.
GUIDED_BAND1 = "4s"
#: Pass-2 band of a guided long take with the default pass-1 band: a third
#: (:data:`BAND2_PER_BAND1`) of this width, as when such takes ran pass 1 in a 20 s band.
#: Pass 2's departure penalty is per band width, so a third of 4 s would weigh departures 5x
#: harder: measured, the left side's mean error rose from 5.20 to 5.43 frames; with this
#: band it stays at 5.20 (both sides equal to the 20 s band's to the last digit).  Pass 2 is
#: cheap (D2 in a 400-frame band: about 1 s a side on 20 minutes).
GUIDED_BAND2_OF = "20s"
#: Pass-1 band width with open ends: the band around the located overlap (the locating pass
#: itself covers the whole hands take).
OPEN_BAND1 = "3s"
#: Pass-2 band width as a share of pass 1's (the paper: 30 % and 10 %).
BAND2_PER_BAND1 = 1.0 / 3.0
#: Standard deviation of the Gaussian that smooths the markers before differentiating, seconds.
SMOOTH_S = 0.025
#: Noise matching (``noise_ratio``): when one take's phase signs change more often than the
#: other's (tempo-compensated), both are smoothed more, stepping through :data:`SMOOTH_STEPS`
#: until the two rates agree within this factor.  1.2 was chosen on seeds 0-2 of the imitation
#: scenario.
NOISE_RATIO = 1.2
#: By default (``noise_ratio="auto"``) noise matching runs when either side's rates differ by
#: more than this factor (one decision for the pair: both arms come from one hands take).
#: Measured on tuning seeds 0-3, the larger of the two sides' rates: the clean scenarios of the
#: protocol (base, extra, short, pauses, speed, rate; both takes) reach at most 1.43, the short
#: clean pairs of the tests 1.65 (their 12-s hands takes carry wrist noise), the bundled sample
#: 1.39; the imitation of a second performance 1.37-2.55 (4 of 8 pairs over 1.7: the four
#: whose default alignment failed) and *all* 2.02-3.83.  Matching at every excess over 1.2 also
#: fired on clean pairs and cost them accuracy (README *Accuracy*; benchmarks/HISTORY.md).
NOISE_TRIGGER = 1.7
#: ``noise_ratio="auto"``, two sides, noise matching not triggered: when the hands' time maps
#: are more than 0.1 s apart in over this share of the body frames, the pair is aligned again
#: with noise matching and the alignment whose hands agree better is kept
#: (:func:`splicer.stages.align.align_pair`).  Measured on tuning seeds 0-3 (all nine
#: scenarios, both takes): where matching gave a different alignment (12 runs), the one whose
#: hands agreed better was the more accurate in every run; the clean scenarios' shares reached
#: 0.36 (so some clean pairs are aligned twice, and keep their first alignment).
RECHECK_SHARE = 0.25
#: With noise matching off, the summary says a take looks noisier above this factor.
NOISE_WARN = 1.6
#: Smoothing widths tried by noise matching, as multiples of ``smooth_s``.
SMOOTH_STEPS = (1.0, 2.0, 4.0, 6.0, 8.0)
#: Pass 1's position term (``position_weight="auto"``, :func:`splicer.align.costs.d1_cost`):
#: D1 units per unit of the mean squared difference of the normalised shoulder-relative wrist
#: and hand positions.  Tuning seeds 0-3 of the nine scenarios (README *Accuracy*; benchmarks/HISTORY.md), weights
#: 0 / 1 / 3 / 10 / 30 on every pair: 3 leaves the clean scenarios as they were or better
#: (synthetic speed 0.051 -> 0.037 s) and 10 or more costs them (synthetic short 0.030 ->
#: 0.037 s at 10); where the arm is noisy (imitation, all) 10 is far better than 3
#: (synthetic all 1.69 -> 0.60 s, zeggs all 0.29 -> 0.15 s).
POSITION_WEIGHT = 3.0
#: ... and where noise matching smoothed the pair (derivative signs are less to be trusted),
#: in every pass of pass 1, open-ended ones included (:func:`splicer.stages.align.position_weights`).
POSITION_WEIGHT_NOISY = 10.0
#: ... and a noisy pair (a second performance) is aligned again with this weight, keeping the
#: pair of time maps along which the hand moves relative to the forearm more alike in both takes
#: (:mod:`splicer.stages.recheck`, 0.18.0; 0 switches it off).  Tuning seeds 0-3, both takes,
#: the noisy scenarios (imitation, *all*, and imitation with speed changes or a pause): the
#: second alignment kept in 19 of 40 pairs, 14 of them better, 2 worse by at most 0.005 s; the
#: synthetic speed + imitation 0.116 -> 0.061 s mean error, pause-hands + imitation 0.042 ->
#: 0.033 and 0.025 -> 0.018 s (benchmarks/HISTORY.md, 0.18.0).  A weight of 30 everywhere would
#: cost the imitation (synthetic 0.030 -> 0.035 s).
POSITION_WEIGHT_RECHECK = 30.0
#: The position term also reads the hand's direction in the forearm's frame
#: (:func:`splicer.align.wrist.hand_in_forearm`), which a second performance's shoulder and elbow
#: noise does not reach: the signs of its three components' velocities (smoothed over
#: :data:`WRIST_SIGN_SMOOTH_S`, each rising linearly to +-1 over :data:`WRIST_SIGN_RAMP` times the
#: component's RMS velocity), scaled by this and appended to the nine position coordinates, so the
#: term is the mean over twelve columns and one sign's full difference (2) counts as 16 squared
#: position units (:func:`splicer.align.costs.position_features`; 0.29.0).  Only where the position
#: term is on and the two takes' hand-in-forearm directions compare
#: (:func:`splicer.align.wrist.markers_compare`), and only in pass 1's DTW at the body's rate (not
#: at the coarser rates of its locating levels or guide, nor in the check against the hands played
#: backwards: at the locating rates it moved one tuning run's overlap by 3 s).  Chosen on
#: tuning seeds 0-14 (*all*, both takes): scale 1 / 2 / 3 gave synthetic 0.045 (0.227) / 0.031
#: (0.125) / 0.033 (0.160) s, zeggs 0.030 (0.128) / 0.028 (0.107) / 0.026 (0.101) s, against 0.051
#: (0.275) and 0.032 (0.144) without (benchmarks/HISTORY.md, 0.29.0).  0 switches it off.
WRIST_SIGN_SCALE = 2.0
#: Optical markers (C3D, TRC, CSV) against optical markers or virtual ones on the styloids
#: (:func:`splicer.stages.align.wrist_signs_compare`): their positions have no root
#: heading to turn them by, so the position term holds the hand-in-forearm signs alone (three
#: columns, :func:`splicer.align.costs.position_features` with ``coordinates=False``), weighed by
#: this (D1 units per unit of the mean squared difference over the three columns; 0 switches it
#: off).  Chosen on the markers' protocol (``benchmarks/eval_markers.py``), tuning seeds 0-9, both
#: takes, among 1.25 / 2.5 / 5 (the signs among nine zero coordinates at weights 5 / 10 / 20):
#: both C3D 0.306 -> 0.295 / 0.293 / 0.296 (seeds 0-4) and 0.343 -> 0.325 / 0.320 frames (5-9) on
#: ZEGGS, 0.560 -> 0.520 / 0.526 / 0.567 and 0.533 -> 0.493 / 0.511 on the synthetic speaker
#: (benchmarks/HISTORY.md, 0.31.0).
OPTICAL_SIGN_WEIGHT = 1.25
#: ... the hand-in-forearm direction's smoothing before its velocity is taken, seconds.
WRIST_SIGN_SMOOTH_S = 0.05
#: ... and the width of each sign's ramp, as a share of that component's RMS velocity.
WRIST_SIGN_RAMP = 0.3
#: ... and, a third candidate, the pair aligned at that weight with each take's phase markers
#: smoothed so that both are blurred over the same span of the performance, the tempo read from
#: the first alignment's maps (:mod:`splicer.align.tempo`; 0.27.0); False leaves it out.
TEMPO_MATCHED = True
#: The second opinion's maps combined frame by frame (0.28.0; 0 keeps one candidate whole): each
#: candidate's map weighed by ``exp(-mismatch / SECOND_OPINION_TAU)``, its hand-in-forearm
#: mismatch (:func:`splicer.align.wrist.local_rate_mismatch`) over the window of this many
#: seconds centred on the frame.  Tuning seeds 0-14, *all*: synthetic 0.054 (0.302) -> 0.051
#: (0.275) s, ZEGGS 0.033 (0.150) -> 0.032 (0.144); the imitation and its combinations within
#: 0.0002 s; held out, synthetic *all* 0.046 (0.197) -> 0.039 (0.155) s (benchmarks/HISTORY.md, 0.28.0).
SECOND_OPINION_BLEND_S = 1.0
#: ... and the mismatch difference that weighs a candidate e times less (0 alike, about 2 for
#: unrelated motion).
SECOND_OPINION_TAU = 0.1
#: ... and where the body's hand moves in its forearm under this share of the median window's
#: motion, the kept pair's map alone (the mismatch is a ratio to that motion: near a rest it read
#: 5-7 for every candidate, and the combination took a start 0.1 -> 0.4 s off; test_close_ends).
SECOND_OPINION_MIN_MOTION = 0.25
#: A second opinion whose time maps lie further than this from the first pair's (the median over
#: the body frames both cover, seconds) placed the hands' material elsewhere altogether: kept, it is
#: kept whole, never combined frame by frame with maps that far away (0.29.1; judged since 0.34.0
#: by :func:`splicer.stages.recheck.coverage_mismatch`, before by each pair's mismatch along the
#: frames it covered itself).  Tuning seeds 0-39, *all*: two such pairs, the synthetic
#: seed 20 (the second opinions mapped the body's first 29 s onto the hands' last 10 s; the
#: common frames kept them, 22.6 s mean error with half of the wrong frames at full confidence;
#: now left out, 0.57 s, 94 % flagged) and seed 24 (the first alignment 2.9 s off, the second
#: opinions right; now kept, 0.027 s); in the other 78 pairs the medians were at most 0.11 s
#: (benchmarks/HISTORY.md, 0.29.1).  Frame by frame too (0.35.0): the combination weighs only
#: the maps within this distance of the one it follows (:func:`splicer.stages.recheck.blend_maps`).
SECOND_OPINION_RELOCATED_S = 1.0
#: How a pair's alternative alignments are judged (0.34.0: the partial-overlap check's two, the
#: first and its second opinions): over the body frames any of them covers, on every side, an
#: alignment's cost per frame is how unlike the hand moves relative to the forearm in the two takes
#: over the second around the frame (:func:`splicer.align.wrist.local_rate_mismatch`, the window
#: :data:`SECOND_OPINION_BLEND_S`: 0 alike, about 2 unrelated) where it covers the frame, at most
#: :data:`JUDGE_MISMATCH_CAP`, and :data:`JUDGE_UNCOVERED` where it leaves the frame uncovered; the
#: least mean is kept (:func:`splicer.stages.recheck.coverage_mismatch`).  Before, each was judged
#: along the frames it covered itself, or the frames all covered: dropping genuine material cost
#: nothing, and a stretch every candidate covered with unrelated material weighed as much as the
#: genuine frames (*all*, ZEGGS tuning seed 24: the body's first 26 s have no hands material; the
#: first alignment matched them to unrelated material and squeezed the genuine start, 3.7 s off;
#: the shorter overlap's second opinion, right there, was judged on frames all three covered and
#: left out).  Uncovered counts as a quarter of the way to unrelated: a frame is worth covering when
#: its material matches better than that (matched frames read 0.05-0.1, frames off by more than
#: 0.1 s 0.5-1, unrelated material 0.8-3).  Tuning seeds 0-39, *all*: measured at 1.0 (as halfway)
#: and 0.5, each with and without the cap (benchmarks/HISTORY.md, 0.34.0).  Also the most one frame
#: costs when the frame-by-frame combination chooses which map to follow (0.35.0,
#: :func:`splicer.stages.recheck.blend_maps`): where every map reads worse, all are as bad as
#: leaving the frame out, and which one is followed there must not decide the rest.  And (0.36.0)
#: the ratio rules at the coverage's edges leave a stretch covered whose median mismatch is under
#: it (:func:`splicer.stages.coverage.uncover_unsure_edges`).
JUDGE_UNCOVERED = 0.5
#: ... and the most one covered frame costs: unrelated motion's level.  Where the body's hand hardly
#: moves in its forearm the ratio reads 5-10 and would outweigh everything else; it says no more
#: than "unrelated".
JUDGE_MISMATCH_CAP = 2.0
#: A third second opinion where the first pair's overlap was located (open ends): the pair aligned
#: at the heavier weight with the uncovered penalty at this quantile of the costs (not
#: :data:`UNCOVERED_QUANTILE`), so a shorter overlap costs less: where the hands' genuine material
#: ends at a third of the body's pace, pass 1 stretched it over the body frames after its true end
#: (the steep stretch costs as much as unrelated material there), then covered more with the extra
#: material.  Taken as a candidate only when it leaves at least :data:`SHORTER_OPINION_LESS_S`
#: seconds of body frames per side more uncovered than the first, and in the frame-by-frame
#: combination only when it is the one kept.  Tuning seeds 0-39, *all*: synthetic 0.0608 (0.366)
#: -> 0.0560 (0.321) s (seed 28: 0.216 (1.812) -> 0.025 (0.081)), ZEGGS 0.0407 (0.210) -> 0.0404
#: (0.210); seeds 0-9 of the imitation and its three combinations the same to the bit
#: (benchmarks/HISTORY.md, 0.32.0).  0 switches it off.
SHORTER_OPINION_QUANTILE = 0.05
SHORTER_OPINION_LESS_S = 2.0
#: The tempo's slope smoothing (a Gaussian's standard deviation, seconds) and its limits
#: (hands seconds per body second): as the prototype measured in benchmarks/HISTORY.md, 0.26.1.
TEMPO_SLOPE_S = 0.5
TEMPO_RANGE = (0.2, 5.0)
#: D1's sign dead zone: components below this share of the motion's RMS velocity
#: (acceleration) count as zero.
DEAD_ZONE = 0.01
#: D1's sign ramp: beyond the dead zone the sign rises linearly to 1 over this share of the
#: motion's RMS velocity (acceleration), so D1 is continuous in the input; 0 is the paper's step.
SIGN_RAMP = 0.03
#: ... and in a noisy pair's pass 1 with fixed ends (noise matching smoothed the markers: a second
#: performance), this share: the arm noise's small velocities then count as little motion, not as
#: a full sign, so a rest between gestures no longer matches the next gesture's onset.  Tuning
#: seeds 0-3 (the imitation and its combinations with speed changes and pauses, both takes):
#: 0.03 / 0.15 / 0.3 / 0.5 with fixed ends only -> synthetic *speed + imitation* 0.040 / - /
#: 0.029 / 0.028 s, imitation 0.021 / - / 0.017 / 0.015 s, 17 and 19 of 40 runs better, 1 and 0
#: worse; open-ended passes too (0.15, 0.3) made *all* worse (zeggs 0.037 -> 0.098 / 0.092 s),
#: so they keep SIGN_RAMP, and so do optical markers, whose measured white noise the wider ramp
#: served worse (synthetic speaker, hands C3D: 0.52 -> 0.55 frames) (benchmarks/HISTORY.md, 0.20.0).
SIGN_RAMP_NOISY = 0.5
#: Pass 1's time map is the expected path over the paths near the best one, each weighted by
#: exp(-cost / (PASS1_TEMPERATURE_S x body fps)) (:mod:`splicer.align.posterior`): a path that
#: costs one D1 unit more per body frame for this many seconds is e times less likely (24 D1
#: units at 30 fps; per second of body time, so the same at any frame rate).  0 takes the best
#: path alone (the paper).
PASS1_TEMPERATURE_S = 0.8
#: Hands time each side of the best path that the weighed paths may use, seconds.
POSTERIOR_RADIUS_S = 2.0
#: Pass 1 costing this share or more of what it costs against the hands take played backwards
#: (:mod:`splicer.align.evidence`): nothing says the takes show the same performance, and every
#: covered frame is low confidence.  Measured on the scenario protocol's tuning seeds 0-1 (every
#: scenario, both takes): genuine pairs 0.29-0.89, a body with another take's hands 0.97-1.03.
BACKWARDS_RATIO = 0.93
#: Pass 2's departure penalty, radians per band width of departure from the pass-1 warp.
PASS2_WEIGHT = 2.0
#: Weight of D1 (normalised by 24) added to D2 in pass 2; 0 is the paper's pass 2.
PASS2_D1_WEIGHT = 0.0
#: Smoothing of the time map, seconds.
TIMEMAP_SIGMA_S = 0.2
#: The time map weighed by the expected path's spread (:mod:`splicer.transfer.trend`): the
#: tempo (hands seconds per body second) drifts as a random walk whose variance grows by this
#: much per second of body time.  Chosen on tuning seeds 0-3 (both takes) between 0.004, 0.0075
#: and 0.015 (benchmarks/HISTORY.md, 0.12.0): 0.004 helps the imitation most and costs *all*;
#: 0.0075-0.015 help or keep every scenario measured.  0 switches the stage off.
TEMPO_VAR_PER_S = 0.01
#: The wrist's refinement of the time map (:mod:`splicer.align.wrist`): offsets searched each
#: side of the map, seconds (0 switches the stage off).  Chosen on tuning seeds 0-3 with the
#: three below and :data:`splicer.align.wrist.LAMBDA` (benchmarks/HISTORY.md, 0.17.0: 0.27 and
#: 0.4 s alike; the offset's smoothing 0.33 s better than 0.2).
WRIST_RADIUS_S = 0.25
#: The markers' smoothing before the hand's direction is differentiated, seconds: the phase
#: metric's own (:data:`SMOOTH_S`, without noise matching's widening).  0.05 and 0.083 measured
#: worse on the tuning seeds, and 0.1-0.2 far worse with optical markers (benchmarks/HISTORY.md, 0.17.0).
WRIST_SMOOTH_S = SMOOTH_S
#: The offset path's smoothing before it moves the map, seconds.
WRIST_OFFSET_SMOOTH_S = 1.0 / 3.0
#: Window of the map's local slope (the hands' tempo), seconds.
WRIST_SLOPE_S = 0.5
#: The wrist's refinement is left out for a side whose optical markers' noise makes up more
#: than this share of the hand's motion relative to the forearm (:func:`splicer.align.wrist.noise_share`;
#: 0.19.0).  Chosen on the tuning seeds 0-4 among 0.15, 0.2, 0.25 and 1/3 (benchmarks/HISTORY.md,
#: 0.19.0): the zeggs take's shares are 0.004-0.03 (never left out); the synthetic speaker's
#: 0.07-0.26 with the hands C3D and 0.17-0.42 with both takes C3D, where the refinement cost more
#: than it gave (both C3D 0.77 -> 0.56 frames at 0.2; hands C3D 0.56 -> 0.58).
WRIST_NOISE_SHARE_MAX = 0.2
#: Most rounds of the wrist's refinement, each from the map the last one left, where the markers carry
#: no measured noise (optical markers: one).  0.19.0: two (tuning seeds 0-3, every scenario's mean
#: error lower or equal, the imitation 0.017 -> 0.013 s and 0.029 -> 0.021 s); 0.26.0: up to six,
#: until settled (tuning seeds 0-4: *all* 0.030 -> 0.028 s and 0.050 -> 0.041 s, every clean
#: scenario's mean lower or equal; a fixed six let clean maps drift, twelve were no better;
#: benchmarks/HISTORY.md).
WRIST_ROUNDS = 6
#: ... at least this many of them (where the markers allow more than one) ...
WRIST_ROUNDS_MIN = 2
#: ... and no more once a round moves the map by less than this on average, seconds of body time
#: (a tenth of a frame at 30 fps).
WRIST_SETTLE_S = 1.0 / 300.0
#: ... and optical markers whose measured noise makes up less than this share of the hand's
#: motion relative to the forearm (:func:`splicer.align.wrist.noise_share`) get those rounds too,
#: against optical markers or virtual ones on the styloids: the noise the second round would fit
#: is not there (0.21.0: the protocol's markers made without noise measure 1e-5 to 1.7e-4, the
#: shared Vicon capture 6.6e-5, the protocol's 1-2 mm of noise 0.004-0.19; benchmarks/HISTORY.md).
WRIST_ROUNDS_NOISE_SHARE_MAX = 1e-3
#: Where the body holds still (pass 1's body holds, :mod:`splicer.align.holds`) its hand does not
#: move in the forearm, and the wrist's refinement has nothing to read: its costs there, and over
#: this many seconds either side (the body slows into and out of a hold), are 0, so the offset
#: is carried across the hold by the offset path's smoothness instead of drifting to wherever the
#: hands move least (0.29.0).  Tuning seeds 0-14, *all*: margin 0 / 0.125 / 0.33 s gave synthetic
#: 0.0298 (0.113) / 0.0296 (0.110) / 0.0300 (0.113) s and zeggs 0.0285 (0.106) / 0.0285 (0.105) /
#: 0.0285 (0.107), against 0.0311 (0.124) and 0.0278 (0.104) reading the hold
#: (benchmarks/HISTORY.md, 0.29.0).  None switches it off.
WRIST_HOLD_MARGIN_S = 0.125
#: Median merge: frames blended each side of a jump.
BLEND_WINDOW_FRAMES = 4
#: Rate of the coarse guide pass of long takes, frames per second.
COARSE_FPS = 5.0
#: Takes longer than this get the coarse guide when ``coarse="auto"``, seconds.
COARSE_ABOVE_S = 120.0
#: Open ends: a body frame left without hands material costs this quantile of the phase
#: metric D1 over a sample of all frame pairs (ALGORITHM.md section 9).
UNCOVERED_QUANTILE = 0.1
#: Open ends: the takes may overlap partly, the hands take starting (ending) with extra material
#: *and* after the body's first (before its last) frame.  An open-ended DTW may then start (end)
#: past both takes' heads (tails) at once, each hands frame skipped beside an uncovered body row
#: costing this fraction of the uncovered penalty, up to one per uncovered row
#: (:func:`splicer.align.dtw.dtw`'s ``both_skip_cost``): as if that row had been covered by a
#: horizontal step at the uncovered penalty's cost (the open passes' horizontal weight, 0.3).
#: Skipped free, the path dropped genuine material where the hands run slowly (tuning seed 3 of
#: *all*: 5-12 s); the weight was taken from that rule, not tuned (benchmarks/HISTORY.md,
#: 0.33.0).  None: starts on row 0 or column 0 only (0.32.0).
BOTH_SKIP_WEIGHT = 0.3
#: ends="auto": an open-ended pass 1 that covers the whole body but leaves hands material at an
#: end (more than a second) is aligned end to end when that material continues the performance:
#: the last (first) CLOSE_ENDS_S seconds of body frames re-aligned with the end fixed at the
#: hands take's last (first) frame cost, per cell, less than CLOSE_ENDS_EXCESS of the way from
#: the open path's cost to the cost of unrelated material (the uncovered penalty)
#: (:func:`splicer.align.openend.close_end`).  A hands take running slower than the body near an
#: end leaves real material behind (the open end is free); a calibration pose or other motion
#: costs like unrelated material.  Tuning seeds 0-3, every scenario, both takes: material that
#: continues the performance 0.08-0.37 (one 0.68, in a second opinion's pass), extra material
#: 0.56-1.9 (benchmarks/HISTORY.md, 0.20.0).
CLOSE_ENDS_S = 2.0
CLOSE_ENDS_EXCESS = 0.45
#: ... and only material up to this long (seconds of hands time, at the body's rate); a longer
#: hands take there is extra material, left open without a look (and the block stays small).  The
#: block only decides: a closed pair is then aligned end to end by pass 1.  10 s (0.20.0) missed a
#: head of 10.1 s by a frame: the ZEGGS *speed + imitation* pair of tuning seed 4, whose hands
#: performer is 0.34x as fast as the body over its first 4.3 s (the protocol's slowest is 0.33x),
#: erred 0.11 s on average, 3.4 s at the start.  At 15 s, tuning seeds 0-4 (extra, speed,
#: speed + imitation, all; both takes): that pair closes (excess -0.40 and -2.3, under 0.45) and
#: errs 0.012-0.015 s; one more head (10.7 s of extra material) is looked at and left open
#: (0.64); no other run changes (benchmarks/HISTORY.md, 0.23.0).
CLOSE_ENDS_MAX_S = 15.0
#: Where the hands' material starts or stops inside the body (an uncovered range begins or
#: ends), the exact frame is located only to within a few frames: covered body frames within
#: this many seconds of an uncovered range have an estimated error of at least this much, so
#: they are low confidence (:mod:`splicer.stages.coverage`).  Tuning seeds 0-3, all nine
#: scenarios: 0.2 / 0.25 / 0.33 / 0.5 s flag 86 / 88 / 90 / 90 % of the zeggs *short*
#: scenario's badly aligned frames (77 % without), 92 / 93 / 93 / 95 % on the synthetic take
#: (86 %), for +0 / +0 / +0 / +0.1 points of good frames on zeggs and +0.4 / +0.6 / +0.7 / +1.2
#: on the synthetic take; held out (seeds 100-104): 58 -> 74 % and 63 -> 76 % (README *Accuracy*).
COVERAGE_EDGE_S = 1.0 / 3.0
#: Open ends: where the hands' material starts (stops) inside the body, a stretch of at least
#: UNSURE_EDGE_S seconds right after (before) it whose every frame's estimated error exceeds
#: UNSURE_EDGE_ERROR_S seconds, and that stops at a sure frame, is taken as uncovered too (:func:`splicer.stages.coverage.unsure_edges`):
#: a hands take that holds material from outside the body's performance (a calibration pose,
#: other gestures) gets matched there, and the alignment knows it is unsure.  Chosen on the
#: tuning seeds 0-3 of the protocol's scenarios (0.5-3 s, 0.1-0.5 s; benchmarks/HISTORY.md, 0.14.0):
#: at 1 s and 0.2 s no frame of the clean scenarios or the imitation changes, and of the body
#: frames of *all* and *short* it takes as uncovered, 1,355 were truly uncovered and 163 covered
#: (137 of those more than 0.1 s off; seeds 4-7: 711 and 182, 26).
UNSURE_EDGE_S = 1.0
UNSURE_EDGE_ERROR_S = 0.2
#: Open ends, then: a stretch of at least UNMATCHED_EDGE_S seconds next to the uncovered frames
#: (the same stretches as above) where the alignment's cost, averaged over UNMATCHED_WINDOW_S
#: seconds, is more than UNMATCHED_RATIO of what the same pass costs against the hands take
#: played backwards (:meth:`splicer.align.evidence.Evidence.local_ratio`) is taken as uncovered
#: too (:func:`splicer.stages.coverage.unmatched_edges`): the hands' material matched there is
#: no better than unrelated.  Chosen on the tuning seeds 0-3 (windows 2-4 s, ratios 0.8-0.9,
#: 1-2 s; benchmarks/HISTORY.md, 0.15.0): of the truly uncovered body frames the earlier stages
#: still gave hands material, it takes 929 of 4,397 and 6 covered frames (seeds 4-7: 496 of
#: 3,999, none covered).  Only where more than COVERAGE_EDGE_S of the body lies uncovered past
#: the stretch (nearer the body's own end the takes start or stop together).
UNMATCHED_EDGE_S = 2.0
UNMATCHED_RATIO = 0.85
UNMATCHED_WINDOW_S = 2.0
#: ... and at the body's own first or last frame, where the path makes the takes look as if they
#: started (stopped) together, the stretch from that frame over which the cost stays above
#: UNMATCHED_OWN_RATIO of the backwards one *on the whole* (the largest sum of the ratio's excess
#: over it, at least UNMATCHED_EDGE_S long and UNMATCHED_OWN_MARGIN_S seconds of excess 1:
#: :func:`splicer.stages.coverage.unmatched_body_ends`): there the hands' material is worse than
#: unrelated, which the takes' own start does not explain (a hands take that starts early and
#: covers only part of the body: the open ends cannot skip both at once).  Chosen on the tuning
#: seeds 0-4 of the nine scenarios, both takes, among bounds 0.8-1.1 and margins 0-1.5 s
#: (benchmarks/HISTORY.md, 0.25.0).
UNMATCHED_OWN_RATIO = 1.0
UNMATCHED_OWN_MARGIN_S = 0.5
#: The estimated error of a frame (:mod:`splicer.stages.risk`) is this quantile of its error
#: under the risk model: the error it exceeds with probability 1 - RISK_QUANTILE.  A frame is
#: flagged when its risk of being 0.1 s off exceeds 1 - RISK_QUANTILE, so that share should be
#: about the protocol's share of such frames: 0.95 until 0.16.0 (5-7 % of the tuning frames more
#: than 0.1 s off), 0.98 since 0.17.0's wrist refinement (2.1 %), checked by cross-validation on
#: the tuning seeds before the held-out seeds were scored (benchmarks/HISTORY.md, 0.17.0).
RISK_QUANTILE = 0.98

#: The passes (``passes``): ``"auto"`` runs both (pass 2: the palm metric D2, narrower band), but
#: pass 1 alone for a side aligned on optical markers (``--hands-markers``/``--body-markers``,
#: ``splice-markers``), whose palm frame, fitted to skin markers a few centimetres apart, is
#: noisier than the pass-1 path it would refine.  Measured on the markers' protocol
#: (``benchmarks/eval_markers.py``, mean error in body frames): both C3D 0.533 -> 0.481 on tuning
#: seeds 0-4 and 0.636 -> 0.586 held out (seeds 100-104; better or equal in every seed), hands
#: C3D with the body's virtual markers 0.591 -> 0.470 and 0.685 -> 0.569 (better in every seed).
#: The virtual markers keep pass 2: it helps the synthetic take's scenarios (benchmarks/HISTORY.md).
PASSES = "auto"

#: Pass 1 of a pair of sides (``pass1_arms``): ``"both"`` aligns both arms with one path, their
#: local costs averaged, since both hands of one hands take were captured on one clock; ``"each"``
#: gives each side its own pass 1 (the paper).  Measured on the ground-truth protocol (tuning
#: seeds 0-3, all nine scenarios, both takes): mean error 0.025-0.037 s -> 0.015-0.028 s on the
#: clean scenarios, imitation 0.061 / 0.163 -> 0.042 / 0.081 s, *all* 0.151 / 0.604 -> 0.071 /
#: 0.120 s (README *Accuracy*; benchmarks/HISTORY.md).
PASS1_ARMS = "both"
#: Body holds (:mod:`splicer.align.holds`): a stretch of at least :data:`HOLD_MIN_S` seconds in
#: which every arm of the body moves slower than :data:`HOLD_SPEED_RATIO` times its median speed
#: (markers smoothed over :data:`HOLD_SMOOTH_S`) is crossed by pass 1 on one hands frame at no cost.
HOLD_SPEED_RATIO = 0.05
HOLD_MIN_S = 0.5
HOLD_SMOOTH_S = 0.05
