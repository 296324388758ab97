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
