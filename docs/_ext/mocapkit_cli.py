"""The command reference, read from the typer app itself: ``.. mocapkit-cli::`` renders every command and
sub-command of ``mocapkit`` (usage, help text, arguments and options with their type and default).

typer 0.29 carries its own copy of click, so sphinx-click cannot read it; this walks the command objects
typer builds and asks each parameter for the help record that ``--help`` prints.
"""

from __future__ import annotations

from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx.util.nodes import make_id


def _context(command, name, parent=None):
    """The command's own context class (typer's copy of click, or click itself for an older typer)."""
    return command.context_class(command, info_name=name, parent=parent)


def _paragraphs(text: str) -> list[nodes.Node]:
    """Help text as plain paragraphs (never parsed as markup: it is written for a terminal)."""
    out = []
    for block in text.replace("\b\n", "").split("\n\n"):
        block = " ".join(line.strip() for line in block.strip().splitlines())
        if block:
            out.append(nodes.paragraph(block, block))
    return out


def command_records(root=None):
    """(path, command, context) for the root and every visible command below it, depth first."""
    import typer

    if root is None:
        from mocapkit.cli import app

        root = typer.main.get_command(app)
    out = []

    def walk(cmd, ctx, path):
        out.append((path, cmd, ctx))
        subs = getattr(cmd, "commands", None) or {}
        for name in cmd.list_commands(ctx) if subs else []:
            sub = subs[name]
            if not getattr(sub, "hidden", False):
                walk(sub, _context(sub, name, ctx), f"{path} {name}")

    walk(root, _context(root, "mocapkit"), "mocapkit")
    return out


def _params(cmd, ctx) -> nodes.Node | None:
    items = nodes.definition_list()
    for p in cmd.params:
        if getattr(p, "hidden", False):
            continue
        record = p.get_help_record(ctx)
        if record is None:
            continue
        names, help_text = record
        item = nodes.definition_list_item()
        item += nodes.term("", "", nodes.literal(names, names))
        item += nodes.definition("", *(_paragraphs(help_text) or [nodes.paragraph("", "")]))
        items += item
    return items if len(items) else None


def _section(path, cmd, ctx, document) -> nodes.section:
    sec = nodes.section(ids=[make_id(None, document, "", "cli-" + path.replace(" ", "-"))])
    sec += nodes.title(path, "", nodes.literal(path, path))
    usage = cmd.get_usage(ctx)
    sec += nodes.literal_block(usage, usage, language="text")
    sec += _paragraphs(cmd.help or "")
    if cmd.epilog:
        sec += _paragraphs(cmd.epilog)
    params = _params(cmd, ctx)
    if params is not None:
        sec += nodes.rubric("Arguments and options", "Arguments and options")
        sec += params
    subs = getattr(cmd, "commands", None)
    if subs:
        names = [n for n in cmd.list_commands(ctx) if not getattr(subs[n], "hidden", False)]
        text = "Commands: " + ", ".join(names)
        sec += nodes.paragraph(text, text)
    return sec


class MocapkitCli(Directive):
    """``.. mocapkit-cli::`` — one section per command, in the app's order (groups before their members)."""

    has_content = False

    def run(self):
        document = self.state.document
        env = document.settings.env
        env.note_dependency(__file__)
        return [_section(path, cmd, ctx, document) for path, cmd, ctx in command_records()]


def setup(app):
    app.add_directive("mocapkit-cli", MocapkitCli)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
