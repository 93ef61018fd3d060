//! The documentation's example output stays true: every fenced block of `README.md` and
//! `docs/*.md` that follows a marker line
//!
//! ```text
//! <!-- output of: grainflow ARGS -->            (the command must exit 0)
//! <!-- output of (exit 1): grainflow ARGS -->   (the command must exit with that code)
//! ```
//!
//! is compared with what `grainflow ARGS` prints (stdout and stderr, from the repository
//! root; ARGS split at spaces, single quotes around an argument dropped): each non-empty line of the block must be a line of the output, with its
//! leading spaces, or, where the block line ends in `…`, the start of one. A `run`
//! command writes into a temporary directory (`--out` is added).
mod common;

use std::path::Path;

use common::run_cli;

/// One marked block: where it is, the command's arguments, the expected exit code and
/// the block's lines.
struct Example {
    place: String,
    args: Vec<String>,
    code: i32,
    lines: Vec<String>,
}

/// The marked blocks of one Markdown file.
fn examples(path: &Path) -> Vec<Example> {
    let text = std::fs::read_to_string(path).expect("readable docs page");
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    for (k, line) in lines.iter().enumerate() {
        let Some(rest) = line.trim().strip_prefix("<!-- output of") else {
            continue;
        };
        let place = format!("{}:{}", path.display(), k + 1);
        let (code, command) = match rest.strip_prefix(" (exit ") {
            Some(r) => {
                let (code, command) = r.split_once("):").expect("`(exit N):` in the marker");
                (code.parse().expect("an exit code in the marker"), command)
            }
            None => (0, rest.strip_prefix(':').expect("`output of:` marker")),
        };
        let command = command.trim().trim_end_matches("-->").trim();
        let args: Vec<String> = command
            .strip_prefix("grainflow ")
            .unwrap_or_else(|| panic!("{place}: the marked command must start with `grainflow`"))
            .split_whitespace()
            .map(|a| a.trim_matches('\'').to_string())
            .collect();
        assert!(
            lines.get(k + 1).is_some_and(|l| l.starts_with("```")),
            "{place}: a fenced block must follow the marker"
        );
        let block = lines[k + 2..]
            .iter()
            .take_while(|l| !l.starts_with("```"))
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.to_string())
            .collect();
        found.push(Example {
            place,
            args,
            code,
            lines: block,
        });
    }
    found
}

#[test]
fn documented_example_output_matches_what_the_commands_print() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages = vec![root.join("README.md")];
    let mut docs: Vec<_> = std::fs::read_dir(root.join("docs"))
        .expect("docs/")
        .map(|e| e.expect("docs entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    let all: Vec<Example> = pages.iter().flat_map(|p| examples(p)).collect();
    assert!(
        all.len() >= 2,
        "expected the marked examples of docs/scene-format.md and docs/output-format.md"
    );
    let out = tempfile::tempdir().expect("temp dir");
    for (n, example) in all.iter().enumerate() {
        let mut args: Vec<String> = example.args.clone();
        if args.first().is_some_and(|a| a == "run") {
            args.push("--out".into());
            args.push(out.path().join(n.to_string()).display().to_string());
        }
        let argv: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, stdout, stderr) = run_cli(&argv);
        let printed = format!("{stdout}{stderr}");
        assert_eq!(
            code, example.code,
            "{}: grainflow {argv:?} exited {code}, the docs say {}\n{printed}",
            example.place, example.code
        );
        for line in &example.lines {
            let found = match line.strip_suffix('…') {
                Some(start) => printed.lines().any(|l| l.starts_with(start)),
                None => printed.lines().any(|l| l == line),
            };
            assert!(
                found,
                "{}: the documented line\n{line}\nis not in the output of grainflow {argv:?}:\n{printed}",
                example.place
            );
        }
    }
}
