//! Runs every command block of `README.md` against a fresh copy of `examples/`, so the README
//! cannot rot.
//!
//! A command block is a fenced ```` ```console ```` block; each line `$ CMD` is a command run by
//! `sh` with the binary under test first on `PATH` (as `omnikin`), in a temporary copy of
//! `examples/` (so every output lands in a temporary directory, and the default output place of
//! `reproduce` is redirected there through `XDG_DATA_HOME`/`HOME`). The lines after a command,
//! up to the next `$`, are what it prints (stdout and stderr as one stream, in the order
//! written). Every console block must be preceded by a marker comment that says how it is
//! checked:
//!
//! * `<!-- readme-test: compare -->` — the printed lines must equal the README's exactly;
//! * `<!-- readme-test: shape REASON -->` — the output depends on timing (a live robot, wall
//!   clock): the same lines must come out with every number replaced by `N`;
//! * `<!-- readme-test: setup -->` — the two set-up commands: `cargo install … && X` runs `X`
//!   with the binary under test (what `cargo install` would install), and `cargo test
//!   --workspace --locked` is skipped (it is the command that runs this test). The reproduce
//!   table that follows it, between `<!-- readme-test: reproduce-table -->` and
//!   `<!-- /readme-test -->`, must equal the printed table. The full default run takes ~18 s
//!   with the test profile's binary (`opt-level = 1`) on the two-core machine, 2.2–4.2 s in
//!   a release build, ~95 s unoptimised (the dynamic profile's fit); `OMNIKIN_README_QUICK=1`
//!   shortens it to `--profiles ideal,hardware,spin-slip --trials 2` and compares only the
//!   table's header and series.
//!
//! A command ending in `&` runs in the background for the rest of its block (its output is
//! compared once the expected number of lines has arrived) and is killed at the block's end.
//! The addresses `127.0.0.1:7000` (the robot, UDP), `127.0.0.1:8090` (the console's page) and
//! `127.0.0.1:8765` (its Foxglove WebSocket) are replaced by free ports, and in a `shape`
//! block a console URL's per-start `token=…` compares as any token. A command whose expected
//! output has a line starting with `error:` must fail; every other command must succeed.
//!
//! `OMNIKIN_README_BLESS=1` rewrites the README's expected outputs with what the commands
//! printed (then review the diff: never hand-write output into the README).

use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_omnikin");
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
/// The README's addresses, each replaced by a free port of its protocol (`true`: UDP).
const PORTS: [(&str, bool); 3] = [
    ("127.0.0.1:7000", true),
    ("127.0.0.1:8090", false),
    ("127.0.0.1:8765", false),
];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Compare,
    Shape,
    Setup,
}

struct Cmd {
    line: String,
    expected: Vec<String>,
}

struct Block {
    mode: Mode,
    /// Line index of the opening fence.
    start: usize,
    /// Line index of the closing fence.
    end: usize,
    cmds: Vec<Cmd>,
}

fn parse(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut blocks = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if l.starts_with("```") && l.trim() != "```" {
            let lang = l.trim_start_matches('`').trim();
            let close = (i + 1..lines.len())
                .find(|&k| lines[k].trim() == "```")
                .unwrap_or_else(|| panic!("README.md:{}: unclosed code block", i + 1));
            if lang == "console" {
                let marker = lines[..i]
                    .iter()
                    .rev()
                    .find(|m| !m.trim().is_empty())
                    .copied()
                    .unwrap_or("");
                let mode = if marker.starts_with("<!-- readme-test: compare") {
                    Mode::Compare
                } else if marker.starts_with("<!-- readme-test: shape ") {
                    Mode::Shape
                } else if marker.starts_with("<!-- readme-test: setup") {
                    Mode::Setup
                } else {
                    panic!(
                        "README.md:{}: a console block needs a marker before it \
                         (<!-- readme-test: compare|shape REASON|setup -->), found {marker:?}",
                        i + 1
                    )
                };
                let mut cmds: Vec<Cmd> = Vec::new();
                for body in &lines[i + 1..close] {
                    if let Some(c) = body.strip_prefix("$ ") {
                        cmds.push(Cmd {
                            line: c.to_string(),
                            expected: Vec::new(),
                        });
                    } else {
                        let c = cmds.last_mut().unwrap_or_else(|| {
                            panic!("README.md:{}: output before the first `$ `", i + 2)
                        });
                        c.expected.push(body.trim_end().to_string());
                    }
                }
                blocks.push(Block {
                    mode,
                    start: i,
                    end: close,
                    cmds,
                });
            }
            i = close + 1;
        } else {
            i += 1;
        }
    }
    blocks
}

/// Copies `examples/` without the firmware crate and without earlier tour outputs.
fn copy_examples(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for e in fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let name = e.file_name();
        if name == "firmware-cortex-m4" || name == "out" {
            continue;
        }
        let (src, dst) = (e.path(), to.join(&name));
        if e.file_type().unwrap().is_dir() {
            copy_examples(&src, &dst);
        } else {
            fs::copy(&src, &dst).unwrap();
        }
    }
}

struct Env {
    dir: PathBuf,
    path: String,
    data: PathBuf,
    home: PathBuf,
    /// The free address standing in for each of [`PORTS`].
    ports: Vec<String>,
}

impl Env {
    fn new(page: &str) -> Self {
        let base = std::env::temp_dir().join(format!(
            "omnikin-readme-{}-{}",
            std::process::id(),
            page.replace('/', "-")
        ));
        let _ = fs::remove_dir_all(&base);
        let (bin, dir) = (base.join("bin"), base.join("examples"));
        fs::create_dir_all(&bin).unwrap();
        std::os::unix::fs::symlink(BIN, bin.join("omnikin")).unwrap();
        copy_examples(&Path::new(ROOT).join("examples"), &dir);
        let (data, home) = (base.join("data"), base.join("home"));
        fs::create_dir_all(&home).unwrap();
        let path = format!(
            "{}:{}",
            bin.display(),
            std::env::var("PATH").unwrap_or_default()
        );
        let ports = PORTS
            .iter()
            .map(|&(_, udp)| {
                let a = if udp {
                    std::net::UdpSocket::bind("127.0.0.1:0")
                        .unwrap()
                        .local_addr()
                } else {
                    std::net::TcpListener::bind("127.0.0.1:0")
                        .unwrap()
                        .local_addr()
                };
                a.unwrap().to_string()
            })
            .collect();
        Env {
            dir,
            path,
            data,
            home,
            ports,
        }
    }

    /// A README line with the free addresses in place of the README's.
    fn to_free(&self, line: &str) -> String {
        PORTS
            .iter()
            .zip(&self.ports)
            .fold(line.to_string(), |l, ((readme, _), free)| {
                l.replace(readme, free)
            })
    }

    /// Printed text with the README's addresses in place of the free ones.
    fn to_readme(&self, text: &str) -> String {
        PORTS
            .iter()
            .zip(&self.ports)
            .fold(text.to_string(), |l, ((readme, _), free)| {
                l.replace(free, readme)
            })
    }

    fn command(&self, line: &str) -> Command {
        // The tour's first command enters examples/; every command here already runs there.
        let line = line.strip_prefix("cd examples && ").unwrap_or(line);
        let mut c = Command::new("sh");
        c.arg("-c")
            .arg(format!("{{ {} ; }} 2>&1", self.to_free(line)))
            .current_dir(&self.dir)
            .env("PATH", &self.path)
            .env("XDG_DATA_HOME", &self.data)
            .env("HOME", &self.home)
            .env("NO_COLOR", "1")
            .stdin(Stdio::null());
        c
    }
}

/// Runs one foreground command: (printed lines, success).
fn run(env: &Env, line: &str) -> (Vec<String>, bool) {
    let t = Instant::now();
    let out = env.command(line).output().expect("cannot run sh");
    assert!(out.stderr.is_empty(), "stderr is merged into stdout");
    let text = env.to_readme(&String::from_utf8_lossy(&out.stdout));
    eprintln!("readme: {:.1} s  $ {line}", t.elapsed().as_secs_f64());
    (tidy(&text), out.status.success())
}

fn tidy(text: &str) -> Vec<String> {
    let mut v: Vec<String> = text.lines().map(|l| l.trim_end().to_string()).collect();
    while v.last().is_some_and(|l| l.is_empty()) {
        v.pop();
    }
    v
}

/// Every number (integer, decimal, exponent, sign) becomes `N`, and a console URL's token
/// (`token=` and its hex digits) becomes `token=T`.
fn mask(line: &str) -> String {
    let mut line = line.to_string();
    let mut from = 0;
    while let Some(i) = line[from..].find("token=") {
        let start = from + i + "token=".len();
        let end = line[start..]
            .find(|c: char| !c.is_ascii_hexdigit())
            .map_or(line.len(), |e| start + e);
        line.replace_range(start..end, "T");
        from = start + 1;
    }
    let mut out = String::new();
    let b: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == '-' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        if starts {
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || (b[i] == '.' && i + 1 < b.len() && b[i + 1].is_ascii_digit())
                    || ((b[i] == 'e' || b[i] == 'E')
                        && i + 1 < b.len()
                        && (b[i + 1].is_ascii_digit() || b[i + 1] == '-')))
            {
                i += if b[i] == 'e' || b[i] == 'E' { 2 } else { 1 };
            }
            out.push('N');
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    out
}

struct Background {
    child: Child,
}

fn read_log(p: &Path) -> Vec<String> {
    let mut s = String::new();
    if let Ok(mut f) = fs::File::open(p) {
        let _ = f.read_to_string(&mut s);
    }
    tidy(&s)
}

/// Outcome of a block: the printed output of each command, and the failures found.
fn check_block(
    env: &Env,
    block: &Block,
    text: &[&str],
    failures: &mut Vec<String>,
) -> Vec<Vec<String>> {
    let full = std::env::var_os("OMNIKIN_README_QUICK").is_none();
    let mut got = Vec::new();
    let mut background: Vec<Background> = Vec::new();
    for (k, c) in block.cmds.iter().enumerate() {
        let at = format!("line {} `$ {}`", block.start + 1, c.line);
        let expect_error = c.expected.iter().any(|l| l.starts_with("error:"));
        if block.mode == Mode::Setup {
            if c.line == "cargo test --workspace --locked" {
                eprintln!(
                    "readme: skipped (the command running this test)  $ {}",
                    c.line
                );
                got.push(c.expected.clone());
                continue;
            }
            let inner = c
                .line
                .strip_prefix("cargo install --locked --path crates/omnikin-cli && ")
                .unwrap_or_else(|| panic!("{at}: unexpected set-up command"));
            assert_eq!(inner, "omnikin reproduce sphere-2019", "{at}");
            let line = if full {
                inner.to_string()
            } else {
                format!("{inner} --profiles ideal,hardware,spin-slip --trials 2")
            };
            let (out, ok) = run(env, &line);
            if !ok {
                failures.push(format!("{at}: failed:\n{}", out.join("\n")));
            }
            check_reproduce(env, text, &out, full, failures);
            got.push(c.expected.clone());
            continue;
        }
        if let Some(bg) = c.line.strip_suffix(" &") {
            let log = env.dir.join(format!(".bg-{}-{k}.log", block.start));
            let f = fs::File::create(&log).unwrap();
            let child = env
                .command(&format!("exec {bg}"))
                .stdout(f.try_clone().unwrap())
                .stderr(f)
                .spawn()
                .unwrap();
            // Its start-up lines are its output (what it prints later, about the sessions the
            // block's commands open, is left out of the README).
            let (t, want) = (Instant::now(), c.expected.len().max(1));
            while read_log(&log).len() < want && t.elapsed() < Duration::from_secs(30) {
                std::thread::sleep(Duration::from_millis(50));
            }
            std::thread::sleep(Duration::from_millis(300));
            let start: Vec<String> = read_log(&log)
                .into_iter()
                .map(|l| env.to_readme(&l))
                .collect();
            background.push(Background { child });
            got.push(start);
            continue;
        }
        let (out, ok) = run(env, &c.line);
        if ok == expect_error {
            failures.push(format!(
                "{at}: expected {}, it {}:\n{}",
                if expect_error { "an error" } else { "success" },
                if ok { "succeeded" } else { "failed" },
                out.join("\n")
            ));
        }
        got.push(out);
    }
    for mut b in background {
        let _ = b.child.kill();
        let _ = b.child.wait();
    }
    for (c, out) in block.cmds.iter().zip(&got) {
        let at = format!("line {} `$ {}`", block.start + 1, c.line);
        let same = match block.mode {
            Mode::Compare => *out == c.expected,
            Mode::Shape => {
                out.len() == c.expected.len()
                    && out.iter().zip(&c.expected).all(|(a, e)| mask(a) == mask(e))
            }
            Mode::Setup => true,
        };
        if !same {
            failures.push(format!(
                "{at} ({:?}): the README shows\n{}\nbut it printed\n{}",
                block.mode,
                c.expected.join("\n"),
                out.join("\n")
            ));
        }
    }
    got
}

/// The README's reproduce table (between its markers) against the printed one.
fn check_reproduce(
    env: &Env,
    text: &[&str],
    printed: &[String],
    full: bool,
    failures: &mut Vec<String>,
) {
    let readme = reproduce_table(text);
    let table: Vec<String> = printed
        .iter()
        .filter(|l| l.starts_with('|'))
        .cloned()
        .collect();
    let ok = if full {
        readme == table
    } else {
        let first = |v: &[String]| -> Vec<String> {
            v.iter()
                .map(|l| l.split('|').nth(1).unwrap_or("").trim().to_string())
                .collect()
        };
        readme.len() == table.len()
            && readme.first() == table.first()
            && first(&readme) == first(&table)
    };
    if !ok {
        failures.push(format!(
            "README.md reproduce table ({}): the README shows\n{}\nbut it printed\n{}",
            if full {
                "full run"
            } else {
                "header and series only, shortened run"
            },
            readme.join("\n"),
            table.join("\n")
        ));
    }
    let default = env.data.join("omnikin/reproduce-sphere-2019");
    for f in ["table.md", "table.csv", "metrics.json"] {
        if !default.join(f).is_file() {
            failures.push(format!("reproduce wrote no {}", default.join(f).display()));
        }
    }
    if env.dir.join("reproduce-sphere-2019").exists() {
        failures.push("reproduce wrote into the current directory".into());
    }
}

fn reproduce_table(text: &[&str]) -> Vec<String> {
    let a = text
        .iter()
        .position(|l| l.trim() == "<!-- readme-test: reproduce-table -->")
        .expect("README.md has no <!-- readme-test: reproduce-table --> marker");
    let b = a + text[a..]
        .iter()
        .position(|l| l.trim() == "<!-- /readme-test -->")
        .expect("the reproduce table has no closing <!-- /readme-test -->");
    text[a + 1..b]
        .iter()
        .filter(|l| l.starts_with('|'))
        .map(|l| l.trim_end().to_string())
        .collect()
}

/// Runs the command blocks of `file` (relative to the repository); README.md must open with
/// the set-up block.
fn run_page(file: &str) {
    let path = Path::new(ROOT).join(file);
    let text = fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let blocks = parse(&text);
    assert!(!blocks.is_empty(), "{file}: no command blocks found");
    if file == "README.md" {
        assert!(
            blocks.len() >= 6,
            "too few command blocks: {}",
            blocks.len()
        );
        assert_eq!(
            blocks[0].mode,
            Mode::Setup,
            "the first command block is the set-up"
        );
    }
    let env = Env::new(file);
    let mut failures = Vec::new();
    let mut outputs = Vec::new();
    for b in &blocks {
        outputs.push(check_block(&env, b, &lines, &mut failures));
    }
    if std::env::var_os("OMNIKIN_README_BLESS").is_some() {
        bless(&path, &lines, &blocks, &outputs);
        return;
    }
    assert!(failures.is_empty(), "{file}:\n{}", failures.join("\n\n"));
    let _ = fs::remove_dir_all(env.dir.parent().unwrap());
}

#[test]
fn every_readme_command_block_runs_and_prints_what_the_readme_shows() {
    run_page("README.md");
}

#[test]
fn every_examples_readme_command_block_runs_and_prints_what_it_shows() {
    run_page("examples/README.md");
}

#[test]
fn every_ros2_page_command_block_runs_and_prints_what_it_shows() {
    run_page("docs/ros2.md");
}

/// Writes the printed outputs into the README (review the diff before committing).
fn bless(path: &Path, lines: &[&str], blocks: &[Block], outputs: &[Vec<Vec<String>>]) {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    for (b, got) in blocks.iter().zip(outputs) {
        out.extend(lines[i..=b.start].iter().map(|s| s.to_string()));
        for (c, g) in b.cmds.iter().zip(got) {
            out.push(format!("$ {}", c.line));
            out.extend(g.iter().cloned());
        }
        i = b.end;
    }
    out.extend(lines[i..].iter().map(|s| s.to_string()));
    fs::write(path, out.join("\n") + "\n").unwrap();
}

/// The manual's bound on the README's length (issue 31): history and detail go to
/// bench/README.md and docs/.
const README_MAX_LINES: usize = 400;

#[test]
fn the_readme_is_at_most_400_lines() {
    let text = fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    let n = text.lines().count();
    assert!(
        n <= README_MAX_LINES,
        "README.md has {n} lines, more than {README_MAX_LINES}: move history to bench/README.md \
         or detail to docs/"
    );
}

/// The manual reads as a manual: no "issue N" (the tracker's numbers mean nothing to a reader;
/// history goes to bench/README.md and git) in the README or docs/.
#[test]
fn the_manual_names_no_issue_numbers() {
    let mut pages = vec![Path::new(ROOT).join("README.md")];
    for e in fs::read_dir(Path::new(ROOT).join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            pages.push(p);
        }
    }
    let mut found = Vec::new();
    for p in &pages {
        let text = fs::read_to_string(p).unwrap();
        for (i, line) in text.lines().enumerate() {
            let lower = line.to_lowercase();
            for (at, _) in lower.match_indices("issue") {
                let rest = lower[at + 5..].trim_start_matches('s').trim_start();
                if rest.starts_with(|c: char| c.is_ascii_digit()) {
                    found.push(format!("{}:{}: {line}", p.display(), i + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "issue numbers in the manual:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_readme_names_only_files_that_exist() {
    // Every relative link target and every `examples/...`, `docs/...`, `bench/...` path.
    let text = fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    let mut missing = Vec::new();
    let mut check = |p: &str| {
        let p = p.split('#').next().unwrap_or("");
        if p.is_empty() || p.contains("://") {
            return;
        }
        // docs/odometry.md, docs/python.md and docs/seeing-the-robot.md come from other
        // branches of the same session (merged by the integrator).
        if [
            "docs/odometry.md",
            "docs/python.md",
            "docs/seeing-the-robot.md",
        ]
        .contains(&p)
        {
            return;
        }
        if !Path::new(ROOT).join(p).exists() {
            missing.push(p.to_string());
        }
    };
    for part in text.split("](").skip(1) {
        check(part.split(')').next().unwrap_or(""));
    }
    for part in text.split('`').skip(1).step_by(2) {
        for w in part.split_whitespace() {
            for prefix in [
                "examples/",
                "docs/",
                "bench/",
                "robots/",
                "scripts/",
                "crates/",
            ] {
                if w.starts_with(prefix) && !w.contains('*') && !w.contains("NNN") {
                    check(w.trim_end_matches([',', '.', ':', ';']));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "README.md names files that are not in the repo: {missing:?}"
    );
}

#[test]
fn mask_replaces_every_number() {
    assert_eq!(mask("t 5.950 s, -0.3 m, 1e-5, v2"), "t N s, N m, N, vN");
    assert_eq!(mask("85 frames ok"), "N frames ok");
    assert_eq!(
        mask("open http://127.0.0.1:8090/?token=9ba55e9733b34171dc2255d1c81e42e8"),
        "open http://N:N/?token=T"
    );
    assert_eq!(
        mask("ws://h/?token=ab12 and token=c"),
        "ws://h/?token=T and token=T"
    );
}

/// `omnikin ARGS --help`.
fn help(args: &[&str]) -> String {
    let o = Command::new(BIN).args(args).arg("--help").output().unwrap();
    assert!(o.status.success(), "omnikin {args:?} --help failed");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The subcommands listed under `Commands:` in a help text (without `help`).
fn subcommands(help: &str) -> Vec<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

fn flags(text: &str) -> Vec<String> {
    let mut v = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while let Some(k) = text[i..].find("--") {
        let s = i + k;
        let mut e = s + 2;
        while e < b.len() && (b[e].is_ascii_lowercase() || b[e].is_ascii_digit() || b[e] == b'-') {
            e += 1;
        }
        let before_ok = s == 0 || !(b[s - 1].is_ascii_alphanumeric() || b[s - 1] == b'-');
        if before_ok && e > s + 2 && b[s + 2].is_ascii_lowercase() {
            v.push(text[s..e].trim_end_matches('-').to_string());
        }
        i = e.max(s + 2);
    }
    v
}

#[test]
fn the_readme_flag_lists_match_help() {
    // Every flag a paragraph of "The commands" names must be a flag of the command(s) it
    // documents (their `--help`, subcommands included): the README may leave flags out (it
    // points to `--help` and `omnikin man` for the complete reference) but never invent one.
    let text = fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    let start = text
        .find("\n## The commands")
        .expect("no \"The commands\" section");
    let end = start + 1 + text[start + 1..].find("\n## ").unwrap();
    let mut checked = 0;
    let mut wrong = Vec::new();
    for para in text[start..end].split("\n\n") {
        if !para.starts_with("**`") {
            continue;
        }
        // The commands a paragraph documents: the first word of each **`…`** heading.
        let mut helps = String::new();
        for head in para.split("**`").skip(1).step_by(1) {
            let head = head.split("`**").next().unwrap_or("");
            let first = head.split_whitespace().next().unwrap_or("");
            if first.starts_with('-') || first.is_empty() {
                continue;
            }
            let top = help(&[first]);
            for sub in subcommands(&top) {
                helps.push_str(&help(&[first, &sub]));
            }
            helps.push_str(&top);
        }
        let known: std::collections::HashSet<String> = flags(&helps).into_iter().collect();
        for f in flags(para) {
            checked += 1;
            if !known.contains(&f) {
                wrong.push(format!("{f} (in: {})", para.lines().next().unwrap_or("")));
            }
        }
    }
    assert!(checked > 50, "only {checked} flags found in The commands");
    assert!(
        wrong.is_empty(),
        "README flags that --help does not know: {wrong:#?}"
    );
}
