"""Every command, option and argument of the command line has help text."""

import argparse

from casadi_sins.cli import build_parser


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            yield from ((name, sub, helps.get(name)) for name, sub in action.choices.items())


def test_every_command_option_and_argument_has_help_text():
    missing = []
    for name, sub, command_help in _subparsers(build_parser()):
        if not command_help or not command_help.strip():
            missing.append(name)
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            if not action.help or action.help == argparse.SUPPRESS or not action.help.strip():
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
    assert not missing, f"no help text: {', '.join(missing)}"


def test_the_report_and_demo_help_say_what_they_write():
    subs = {name: sub for name, sub, _ in _subparsers(build_parser())}
    report = next(a for a in subs["calibrate"]._actions if "--report" in a.option_strings)
    assert "JSON" in report.help and "PNG" in report.help
    demo_out = next(a for a in subs["demo"]._actions if "--out" in a.option_strings)
    assert "runs/demo" in demo_out.help
    assert "c" in next(a for a in subs["export"]._actions if "--format" in a.option_strings).choices


def test_every_help_page_has_a_description_and_every_default_is_stated():
    unstated = []
    for name, sub, command_help in _subparsers(build_parser()):
        assert sub.description and sub.description == command_help, name
        for action in sub._actions:
            if (action.option_strings and action.help != argparse.SUPPRESS
                    and action.default not in (None, False, argparse.SUPPRESS) and "default" not in action.help):
                unstated.append(f"{name} {action.option_strings[0]}")
    assert not unstated, f"default not stated: {', '.join(unstated)}"


def test_analyze_refuses_the_old_per_sample_noise_with_a_hint(tmp_path, capsys):
    from casadi_sins.cli import main

    assert main(["analyze", "problems/kang2013.toml", "--out", str(tmp_path), "--gyro-noise-deg-h", "0.01"]) == 2
    err = capsys.readouterr().err
    assert "--gyro-arw-deg-rth" in err and err.count("\n") == 1
