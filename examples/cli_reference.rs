//! Writes `docs/cli.md`, the CLI reference, from the clap definitions themselves, so it cannot
//! drift from `--help`: `cargo run --example cli_reference > docs/cli.md`. `.ci/run` regenerates
//! it and fails when the committed page differs.

use std::fmt::Write as _;

use clap::CommandFactory;

/// Help is wrapped at this width whatever the terminal, so the page is the same everywhere.
const WIDTH: usize = 100;

fn main() {
    let mut cli = autoact::cli::Cli::command().term_width(WIDTH);
    cli.build();
    let mut page = String::from(
        "# CLI reference\n\n\
         Generated from the command-line definitions by `cargo run --example cli_reference > \
         docs/cli.md` (CI checks it is current): each section is that command's `--help`. Back \
         to the [README](../README.md); the manual pages explain each stage.\n\n\
         | command | manual |\n|---|---|\n\
         | `rig`, `layouts`, `import`, `convert`, `info` | [convert.md](convert.md) |\n\
         | `convert --dsi …` | [dsi.md](dsi.md) |\n\
         | `record`, `recover` | [record.md](record.md) |\n\
         | `plan`, `convert --spec` | [dataset.md](dataset.md) |\n\
         | `render` | [render.md](render.md) |\n\
         | `trim` | [trim.md](trim.md) |\n\
         | `export` | [export.md](export.md) |\n\n## autoact\n\n```text\n",
    );
    page.push_str(cli.render_long_help().to_string().trim_end());
    page.push_str("\n```\n");
    for sub in cli.get_subcommands_mut().filter(|s| s.get_name() != "help") {
        let name = sub.get_name().to_owned();
        let help = sub.render_long_help().to_string();
        let _ = write!(
            page,
            "\n## autoact {name}\n\n```text\n{}\n```\n",
            help.trim_end()
        );
    }
    // Lines end without trailing spaces (clap pads some), so the page diffs cleanly.
    let page: String = page
        .lines()
        .map(|l| l.trim_end().to_owned() + "\n")
        .collect();
    std::io::Write::write_all(&mut std::io::stdout().lock(), page.as_bytes())
        .unwrap_or_else(|e| panic!("cannot write the page: {e}"));
}
