"""``station diagnose`` on multi-channel captures: a hidden coupling is named, a linear null is not."""

from __future__ import annotations

import json

import pytest

from simulated_rig.mdof_systems import MdofSystem, load_mdof_system, mdof_impact_test
from station.cli import main


def _captures(system: MdofSystem, tmp_path, tag: str) -> list[str]:
    out = []
    for k, peak in enumerate(system.impacts_n):
        rec = mdof_impact_test(system, peak, seed=10 + k, record_s=2.0)
        out.append(str(rec.write_csv(tmp_path / f"{tag}-{k}.csv")))
    return out


def test_hidden_cubic_coupling_is_named_and_linear_null_is_not(tmp_path, capsys):
    chain = load_mdof_system("two-mass-cubic")
    files = _captures(chain, tmp_path, "cubic")
    assert main(["diagnose", *files, "--json", "--no-refine", "--save-model", str(tmp_path / "m.json")]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["cause"] == "modal_coupling"
    assert obj["unstable"] is False and obj["warnings"] == []  # a sound model: exit 0, no warning
    assert obj["coupled"]["nrmse"] < 0.5 * obj["baseline"]["nrmse"]
    assert main(["validate", str(tmp_path / "m.json"), files[0], "--json"]) == 0
    val = json.loads(capsys.readouterr().out)
    assert set(val["channel_nrmse"]) == {"acc1", "acc2"}
    linear = chain.model_copy(update={"elements": tuple(e.model_copy(update={"k3": 0.0}) for e in chain.elements)})
    files = _captures(linear, tmp_path, "linear")
    assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["cause"] == "none"


def test_energy_sink_is_named_a_nonlinear_coupling_in_physical_coordinates(tmp_path, capsys):
    # the sink has no linear stiffness: no linear mode describes its motion, so the coordinates are
    # the physical channels; its purely cubic attachment is a coupling between them, found held out
    files = _captures(load_mdof_system("nes"), tmp_path, "nes")
    assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["coordinates"] == "physical"
    assert obj["coupled"]["nrmse"] < 0.5 * obj["baseline"]["nrmse"]
    assert any("no linear mode of its own" in n for n in obj["notes"])
    # named only when the coupled model leaves every channel within 10x its noise floor
    # (eddi.mdof.verdict); without the output-error polish the sink channel may stay above it,
    # and then coupling is reported as the best partial explanation, with the channel as symptom
    worst = max(obj["coupled"]["channel_nrmse"][c] / obj["noise_floor"][c] for c in obj["channels"])
    if worst <= 10.0:
        assert obj["cause"] == "modal_coupling"
    else:
        assert obj["cause"] == "unexplained"
        assert any("best partial explanation" in n for n in obj["notes"])
        assert any(s["ratio"] > 10.0 for s in obj["symptoms"])
    # the attachment is purely cubic: (x1 - x2)^3 in the sink's equation, no linear spring to the primary
    assert "x1^3" in obj["coupling_coefficients"][1] and "x1" not in obj["coupling_coefficients"][1]


def test_a_diagnosis_over_its_cpu_budget_says_so_with_its_projection():
    from station.mdof_folds import BUDGET_CPU_S, budget_line

    # 3 folds plus the final identification: 40 s per fold projects 160 s, over the budget
    line = budget_line(1, 3, 40.0, refine=True, budget_s=120.0)
    assert line is not None and "1 of 3 held-out folds took 40 s CPU" in line and "about 160 s CPU" in line
    assert "--no-refine" in line
    assert "--no-refine" not in budget_line(2, 3, 80.0, refine=False, budget_s=120.0)
    assert budget_line(1, 3, 29.0, refine=True, budget_s=120.0) is None  # 116 s: within
    assert budget_line(0, 3, 500.0, refine=True) is None
    assert BUDGET_CPU_S > 0


def test_clipped_driving_point_turns_a_null_into_unexplained(tmp_path, capsys):
    """The chain rule of the one-coordinate loop (eddi.diagnosis.earn) on the driving point:
    the linear null of the test above, its driving-point accelerometer flat at its largest
    value for 3 samples at each blow's peak (a converter at its limit for a moment: too short
    for the reader's 5-sample refusal), is `unexplained` with the clipping as symptom, not
    `none`."""
    import numpy as np

    chain = load_mdof_system("two-mass-cubic")
    linear = chain.model_copy(update={"elements": tuple(e.model_copy(update={"k3": 0.0}) for e in chain.elements)})
    files = _captures(linear, tmp_path, "linear")
    for f in files:
        with open(f) as fh:
            head = fh.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", skiprows=1)
        k = head.index("acc1")
        sign = 1.0 if data[:, k].max() >= -data[:, k].min() else -1.0
        y = sign * data[:, k]
        i = int(np.argmax(y))
        top = float(min(y[i - 1:i + 2]))  # the peak and its two neighbours flat at the lowest of them
        assert np.sum(y > top) <= 2
        data[:, k] = sign * np.minimum(y, top)
        np.savetxt(f, data, delimiter=",", header=",".join(head), comments="", fmt="%.10g")
    assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["cause"] == "unexplained"
    clip = [s for s in obj["symptoms"] if s["kind"] == "clipping"]
    assert clip and all(s["channel"] == "acc1" and 3 <= s["samples"] < 5 for s in clip)
    assert any("measurement chain cannot be trusted" in n for n in obj["notes"])


def test_similar_blows_earn_none_only_when_the_backbone_holds_and_say_how_far(tmp_path, capsys):
    # our own pair (not a rig system), three blows within 25 % of each other: the folds cannot
    # test amplitude extrapolation. Hidden: quadratic drag on mass 1, which no library term
    # carries (the models' damping is linear in the rates); the ring-downs' damping ratio grows
    # with the amplitude and a linear dashpot cannot follow it
    from eddi.mdof.model import MdofModel

    pair = MdofSystem(name="pair", masses_kg=(1.1, 0.45), elements=(
        {"between": (0, 1), "k": 38000.0, "c": 4.5}, {"between": (1, 2), "k": 21000.0, "c": 1.3}), record_s=2.0)
    linear = pair.model()
    damping = ({**linear.damping[0], "abs(v1)*v1": 45.0},) + linear.damping[1:]
    drag: MdofModel = linear.model_copy(update={"damping": damping})
    out = {}
    for tag, model in (("linear", linear), ("drag", drag)):
        files = [str(mdof_impact_test(pair, p, seed=30 + k, model=model).write_csv(tmp_path / f"{tag}-{k}.csv"))
                 for k, p in enumerate((45.0, 50.0, 55.0))]
        assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
        out[tag] = json.loads(capsys.readouterr().out)
    null, hidden = out["linear"], out["drag"]
    assert null["cause"] == "none" and not [s for s in null["symptoms"] if s["kind"] == "amplitude_dependence"]
    assert null["amplitude"]["span"]["extrapolation_tested"] is False
    assert any("extrapolation in amplitude not tested" in n for n in null["notes"])
    assert hidden["cause"] == "unexplained"
    # the first mode's damping departs most; since session 11 (the floor's least value 0.01, allowance
    # 0.035) the second mode's is a symptom too (its records 0.0113 -> 0.0123 with amplitude, the
    # model 0.0125 throughout: about 0.044 implied)
    amps = [s for s in hidden["symptoms"] if s["kind"] == "amplitude_dependence"]
    amp = min(amps, key=lambda s: s["mode_hz"])
    assert amp["model_zeta"] > amp["measured_zeta"] and amp["implied_nrmse"] > amp["allowed"]
    assert amp["mode_hz"] == pytest.approx(min(hidden["natural_frequencies_hz"]), rel=0.05)
    # the human text says how far the verdict was tested
    from station.mdof_commands import diagnose_mdof_text

    assert "Cause: none (within" in diagnose_mdof_text(null)
    assert "extrapolation in amplitude not tested" in diagnose_mdof_text(null)


def test_folds_are_polished_where_the_verdict_or_a_printed_channel_figure_needs_it(monkeypatch):
    import math
    from types import SimpleNamespace

    import eddi.mdof.verdict
    import station.mdof_polish as mc

    def fold(e):
        return SimpleNamespace(nrmse=e, channel_nrmse={"acc1": e, "acc2": e})

    calls = []

    def polished(ident, train, held, v):  # a polish that halves the error
        calls.append(ident)
        return fold(v.nrmse / 2)

    monkeypatch.setattr(mc, "polished_fold", polished)
    monkeypatch.setattr(eddi.mdof.verdict, "channel_floor", lambda records, names: {c: 0.02 for c in names})

    def fits(base, cpl):
        return [{"baseline": (fold(b), f"b{k}", []), "coupled": (fold(c), f"c{k}", [])}
                for k, (b, c) in enumerate(zip(base, cpl))]

    # coupling wins by far and every channel's coupled figure is within 0.05: nothing is polished
    # (the fold at 1.5 > 1 never is; session 11); the coupled figures are printed as upper bounds
    # of the delivered (polished) kind. (Until session 14 that fold was at 40: a baseline that grew
    # past 2x the signal is no longer counted in the gain, eddi.mdof.verdict.baseline_ran.)
    f = fits([0.5, 1.5, 0.6], [0.03, 0.02, 0.04])
    assert mc.polish_folds(f, [None] * 3, ("acc1", "acc2"), margin=0.5) == {"baseline": [], "coupled": []}
    assert calls == []
    # the same win with a channel figure above 0.05: the coupled folds are polished, so the printed
    # figure is the delivered kind's (session 12: t-two-cubic-2k printed 0.060 / 0.061 unpolished)
    f = fits([0.5, 1.5, 0.6], [0.06, 0.05, 0.07])
    done = mc.polish_folds(f, [None] * 3, ("acc1", "acc2"), margin=0.5)
    assert done == {"baseline": [], "coupled": [0, 1, 2]} and calls == ["c0", "c1", "c2"]
    assert [x["baseline"][0].nrmse for x in f] == [0.5, 1.5, 0.6]
    assert [x["coupled"][0].nrmse for x in f] == [0.03, 0.025, 0.035]
    # with a diverged (infinite) baseline fold: it stays infinite and is not counted (session 14), so
    # the gain is judged on the other two folds, where a polished baseline may win: those are polished
    f = fits([0.5, math.inf, 0.6], [0.06, 0.05, 0.07])
    assert mc.polish_folds(f, [None] * 3, ("acc1", "acc2"), margin=0.5)["baseline"] == [0, 2]
    assert [x["baseline"][0].nrmse for x in f] == [0.25, math.inf, 0.3]
    # the 10 kHz chain's folds (bench_mdof_diagnose_cost.py): no polish can take gain 0.98 under 0.1
    # and the coupled figures are within 0.05: neither kind is polished (s12mfit's always-polish
    # cost it +52 % CPU to print 0.0070 where the bound says 0.020)
    calls.clear()
    f = fits([1.19, 1.18, 0.69, 1.13], [0.022, 0.023, 0.019, 0.014])
    assert mc.polish_folds(f, [None] * 4, ("acc1", "acc2"), margin=0.1) == {"baseline": [], "coupled": []}
    assert calls == []
    # baseline folds all within the polish's reach: polished to the floor they would win, so they are polished
    calls.clear()
    f = fits([0.5, 0.7, 0.6], [0.03, 0.02, 0.04])
    assert mc.polish_folds(f, [None] * 3, ("acc1", "acc2"), margin=0.5)["baseline"] == [0, 1, 2]
    assert [x["baseline"][0].nrmse for x in f] == [0.25, 0.35, 0.3]
    assert calls == ["b0", "b1", "b2"]
    # a coupled polish that predicts worse is still the figure (the delivered kind); a baseline one is not kept
    monkeypatch.setattr(mc, "polished_fold", lambda ident, train, held, v: fold(v.nrmse * 1.5))
    f = fits([0.06, 0.05, 0.07], [0.04, 0.03, 0.05])
    assert mc.polish_folds(f, [None] * 3, ("acc1", "acc2"), margin=0.5) == {"baseline": [0, 1, 2],
                                                                             "coupled": [0, 1, 2]}
    assert [x["baseline"][0].nrmse for x in f] == [0.06, 0.05, 0.07]
    assert [round(x["coupled"][0].nrmse, 6) for x in f] == [0.06, 0.045, 0.075]
    # the text says which kind's figures are polished
    obj = {"polished_folds": {"baseline": [], "coupled": [0, 1, 2]}, "baseline": {"folds": [1, 2, 3]},
           "coupled": {"folds": [1, 2, 3]}}
    assert mc.polish_tag(obj, "coupled") == "   (folds polished)"
    assert "0 of 3 folds polished" in mc.polish_tag(obj, "baseline")
    assert mc.polish_tag({**obj, "polished_folds": None}, "coupled") == ""


def test_an_unstable_or_diverging_mdof_model_is_flagged() -> None:
    # the flags behind station diagnose's exit code 1 on multi-channel captures: a linear part
    # with a growing mode (negative damping on one mass), or a held-out simulation that diverged
    import math

    from station.mdof_commands import _model_flags

    sound = load_mdof_system("two-mass-cubic").model()
    assert _model_flags(sound, [0.02, 0.03]) == []
    assert _model_flags(sound, [0.02, math.inf]) == ["the model's simulation diverged on a held-out capture"]
    damping = tuple({t: -abs(c) for t, c in d.items()} for d in sound.damping)
    grows = sound.model_copy(update={"damping": damping})
    (w,) = _model_flags(grows, [0.02, 0.03])
    assert "linear part is unstable" in w and "grows at" in w


def test_modal_coupling_needs_a_determined_nonlinear_coupling_coefficient():
    # blind unseen9 (session 12): uncoupled folds all diverged, the coupled model "won" by 100 %
    # with every nonlinear coupling coefficient's interval 3-20x its value: no coupling is earned
    import station.mdof_commands as mc

    def obj(coeffs):
        return {"cause": "modal_coupling", "gain": 1.0, "notes": [], "coupling_coefficients": coeffs}

    undetermined = obj([{"x1*x2^2": [-2.0e12, 1.4e13], "x2": [-472.1, 370.0], "x2^3": [9.4e12, 5.7e13]},
                        {"x1": [61.8, 25.0], "x1^3": [4.6e10, 5.3e10]}])
    mc._coupling_determined(undetermined)
    assert undetermined["cause"] == "unexplained"  # the determined terms are linear cross terms only
    assert "none of its 3 nonlinear coupling coefficients is determined" in undetermined["notes"][0]
    one = obj([{"x1*x2^2": [-2.0e12, 1.4e13], "x2^3": [9.4e12, 5.7e12]}, {}])
    mc._coupling_determined(one)
    assert one["cause"] == "modal_coupling" and one["notes"] == []
    no_intervals = obj([{"x2^3": [9.4e12, None]}, {}])  # without the polish no intervals: not judged
    mc._coupling_determined(no_intervals)
    assert no_intervals["cause"] == "modal_coupling"
