//! References, checked: every repository file and every section that the
//! repository's text cites must exist (the `references` stage of `cargo xtask
//! test`; alone: `cargo xtask check-refs`).
//!
//! Scanned: the `*.md`, `*.rs`, `*.toml`, `*.py` and `*.sh` files under the root,
//! except generated and third-party directories ([`SKIPPED_DIRS`]) and this
//! checker's fixture ([`FIXTURE`]). Markdown is read whole; in the other files
//! comments are read as prose (consecutive comment lines joined, so that a
//! quoted title may run over a line break) and string literals more strictly,
//! and the code between them not at all.
//!
//! What counts as a reference:
//!
//! - **a repository path**: a token with a `/` whose first component is one of
//!   the root's directories (`docs/x.md`, `crates/a/src/b.rs`, `config/`), in
//!   prose or in a string; in prose also a token with a `/` that ends in a source
//!   or data extension and starts with the name of a directory of the repository
//!   (`src/board/mps2.rs`, `hil-tests/tests/envelope.rs`), an upper-case document
//!   name (`ARCHITECTURE.md`), and every Markdown link target. Such a token
//!   resolves against the root, the citing file's directory or its package's
//!   directory, or else as the end of exactly one repository path (more than one
//!   is ambiguous). Relative tokens (`../config`) resolve against the citing
//!   file's directory or one of its ancestors, and must stay inside the root.
//!   Brace lists (`figure.{png,svg}`) must exist for every alternative, `*` must
//!   match something. Not checked: tokens with placeholders (`<board>`, `...`, a format string's `{}`,
//!   an upper-case directory such as `DIR/`), alternative extensions
//!   (`plot.png/.svg`), paths into generated directories ([`GENERATED`]:
//!   `target/`, `out/`), and another crate's files written with that crate's
//!   name first (`stm32f4xx-hal/src/serial.rs`); an absolute path into the build
//!   machine (`/work/...`) is a violation;
//! - **a section**: `file.md §N` (`§N.M`, `§N-M`, `§N "Title"`, and `, §K` or
//!   `and §K` continuing the list) needs a heading numbered N in that file;
//!   `NAME §N` is `NAME.md §N`; a bare `§N` is the Markdown file's own section,
//!   or in a comment the last Markdown file cited above it; `file.md, "Title"`
//!   (and `and "Other"` continuing it) needs a heading or a bold paragraph lead
//!   that starts with the title; a link's `#anchor` needs a heading with that
//!   GitHub anchor.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Component, Path, PathBuf};

use regex::Regex;

use crate::process::Result;

/// Directories never scanned (build output, environments, version control).
pub const SKIPPED_DIRS: &[&str] = &[
    "target",
    "out",
    ".git",
    ".venv",
    "node_modules",
    "__pycache__",
];
/// Path components whose paths are generated, not part of the repository: a
/// reference into them is not checked.
pub const GENERATED: &[&str] = &["target", "out", ".venv", "__pycache__"];
/// The checker's own fixture (references that must fail), relative to the root.
pub const FIXTURE: &str = "xtask/fixtures/refs";
/// What the stage does not read, relative to the root: the fixture, and this
/// checker's source, whose documentation and tests show references that do not
/// exist.
pub const NOT_READ: &[&str] = &[FIXTURE, "xtask/src/refs.rs"];
/// What a reference to a path that does not exist is told.
const MISSING: &str = "no such file or directory in the repository";
/// Extensions of the files scanned.
const SCANNED: &[&str] = &["md", "rs", "toml", "py", "sh"];
/// Extensions that make a prose token with a `/` a file reference.
const FILE_EXTENSIONS: &[&str] = &[
    "md", "rs", "toml", "py", "sh", "csv", "json", "x", "txt", "yml", "yaml", "svg", "png", "lock",
];

/// One reference that does not resolve.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Violation {
    /// The citing file, relative to the root.
    pub file: String,
    /// Its 1-based line.
    pub line: usize,
    /// The reference as written.
    pub reference: String,
    /// What is missing.
    pub problem: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}:{}: `{}`: {}",
            self.file, self.line, self.reference, self.problem
        )
    }
}

/// The stage: every reference under `root` resolves, or the error lists those
/// that do not.
pub fn check(root: &Path) -> Result<()> {
    let (files, violations) = check_tree(root, NOT_READ)?;
    if violations.is_empty() {
        println!("references: {files} files, every cited file and section exists");
        Ok(())
    } else {
        let list: Vec<String> = violations.iter().map(Violation::to_string).collect();
        Err(format!(
            "{} references to files or sections that do not exist:\n  {}",
            violations.len(),
            list.join("\n  ")
        ))
    }
}

/// Checks every scanned file under `root` but those under `skip` (relative
/// paths); returns the number of files read and the violations, sorted.
pub fn check_tree(root: &Path, skip: &[&str]) -> Result<(usize, Vec<Violation>)> {
    let checker = Checker::new(root)?;
    let mut files = Vec::new();
    collect(root, root, skip, &mut files)?;
    files.sort();
    let mut violations = Vec::new();
    for file in &files {
        let text =
            fs::read_to_string(file).map_err(|e| format!("cannot read {}: {e}", file.display()))?;
        checker.check_file(file, &text, &mut violations);
    }
    violations.sort();
    violations.dedup();
    Ok((files.len(), violations))
}

/// The scanned files under `dir`.
fn collect(root: &Path, dir: &Path, skip: &[&str], out: &mut Vec<PathBuf>) -> Result<()> {
    let entries = fs::read_dir(dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    for entry in entries {
        let entry = entry.map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        let relative = relative(root, &path);
        if skip.iter().any(|s| relative == *s) {
            continue;
        }
        let kind = entry
            .file_type()
            .map_err(|e| format!("cannot stat {}: {e}", path.display()))?;
        if kind.is_dir() {
            if !SKIPPED_DIRS.contains(&name.as_str()) && !name.starts_with('.') {
                collect(root, &path, skip, out)?;
            }
        } else if kind.is_file()
            && path
                .extension()
                .is_some_and(|e| SCANNED.contains(&e.to_string_lossy().as_ref()))
        {
            out.push(path);
        }
    }
    Ok(())
}

/// `path` relative to `root`, with `/` separators.
fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join("/")
}

/// How a piece of text is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Markdown, or a comment: every kind of reference.
    Prose,
    /// A string literal: repository paths and the sections they cite only.
    Literal,
}

/// A run of text from one file, with the source line of each of its parts.
#[derive(Debug)]
struct Region {
    kind: Kind,
    text: String,
    /// `(offset in text, 1-based source line)`, offsets increasing.
    lines: Vec<(usize, usize)>,
}

impl Region {
    fn new(kind: Kind, line: usize) -> Self {
        Region {
            kind,
            text: String::new(),
            lines: vec![(0, line)],
        }
    }

    /// Continues the region with a part from source line `line`.
    fn push_line(&mut self, line: usize) {
        if !self.text.is_empty() && !self.text.ends_with(' ') {
            self.text.push(' ');
        }
        self.lines.push((self.text.len(), line));
    }

    fn line_at(&self, offset: usize) -> usize {
        let i = self.lines.partition_point(|(o, _)| *o <= offset);
        self.lines[i.saturating_sub(1)].1
    }
}

/// The regions of `text`, by the file's kind.
fn regions(extension: &str, text: &str) -> Vec<Region> {
    match extension {
        "md" => {
            let mut region = Region::new(Kind::Prose, 1);
            for (i, line) in text.lines().enumerate() {
                region.push_line(i + 1);
                region.text.push_str(line.trim());
            }
            vec![region]
        }
        "rs" => lex(text, Syntax::Rust),
        "sh" => lex(text, Syntax::Shell),
        _ => lex(text, Syntax::Hash),
    }
}

/// The comment and string syntax of a source file.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Syntax {
    /// `//` and `/* */` comments; `"..."`, raw strings, char literals.
    Rust,
    /// `#` comments at the start of a word; `"..."` and `'...'`.
    Shell,
    /// `#` comments; `"..."`, `'...'` and their tripled forms (TOML, Python).
    Hash,
}

/// Splits source text into comment regions (consecutive line comments joined)
/// and string-literal regions.
fn lex(text: &str, syntax: Syntax) -> Vec<Region> {
    let chars: Vec<char> = text.chars().collect();
    let mut out: Vec<Region> = Vec::new();
    // The last line comment's region index and line, to join the next one.
    let mut comment_run: Option<(usize, usize)> = None;
    let mut line = 1;
    let mut i = 0;
    let mut code_on_line = false;
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '\n' {
            line += 1;
            code_on_line = false;
            i += 1;
            continue;
        }
        let line_comment = match syntax {
            Syntax::Rust => c == '/' && next == Some('/'),
            Syntax::Shell => {
                c == '#' && (i == 0 || chars[i - 1].is_whitespace() || chars[i - 1] == ';')
            }
            Syntax::Hash => c == '#',
        };
        if line_comment {
            let mut j = i;
            while j < chars.len() && (chars[j] == '/' || chars[j] == '#' || chars[j] == '!') {
                j += 1;
            }
            let end = chars[j..]
                .iter()
                .position(|&c| c == '\n')
                .map_or(chars.len(), |p| j + p);
            let content: String = chars[j..end].iter().collect();
            let joined = match comment_run {
                Some((index, last)) if last + 1 == line && !code_on_line => Some(index),
                _ => None,
            };
            let index = match joined {
                Some(index) => index,
                None => {
                    out.push(Region::new(Kind::Prose, line));
                    out.len() - 1
                }
            };
            let region = &mut out[index];
            region.push_line(line);
            region.text.push_str(content.trim());
            comment_run = Some((index, line));
            i = end;
            continue;
        }
        if syntax == Syntax::Rust && c == '/' && next == Some('*') {
            let mut region = Region::new(Kind::Prose, line);
            let mut depth = 1;
            let mut j = i + 2;
            region.push_line(line);
            while j < chars.len() && depth > 0 {
                if chars[j] == '/' && chars.get(j + 1) == Some(&'*') {
                    depth += 1;
                    j += 2;
                } else if chars[j] == '*' && chars.get(j + 1) == Some(&'/') {
                    depth -= 1;
                    j += 2;
                } else {
                    if chars[j] == '\n' {
                        line += 1;
                        region.push_line(line);
                    } else {
                        region.text.push(chars[j]);
                    }
                    j += 1;
                }
            }
            out.push(region);
            i = j;
            continue;
        }
        // Strings.
        let (open, close_len, raw) = match syntax {
            Syntax::Rust if c == '"' => (Some('"'), 1, false),
            Syntax::Rust
                if (c == 'r' || (c == 'b' && next == Some('r')))
                    && (i == 0 || !ident(chars[i - 1])) =>
            {
                let start = if c == 'b' { i + 2 } else { i + 1 };
                let hashes = chars[start..].iter().take_while(|&&c| c == '#').count();
                if chars.get(start + hashes) == Some(&'"') {
                    // A raw string: its end is a quote and as many hashes.
                    let body = start + hashes + 1;
                    let mut region = Region::new(Kind::Literal, line);
                    let mut j = body;
                    while j < chars.len() {
                        if chars[j] == '"'
                            && chars[j + 1..]
                                .iter()
                                .take(hashes)
                                .filter(|&&c| c == '#')
                                .count()
                                == hashes
                        {
                            break;
                        }
                        if chars[j] == '\n' {
                            line += 1;
                            region.push_line(line);
                        } else {
                            region.text.push(chars[j]);
                        }
                        j += 1;
                    }
                    out.push(region);
                    code_on_line = true;
                    i = j + 1 + hashes;
                    continue;
                }
                (None, 0, false)
            }
            Syntax::Rust if c == '\'' => {
                // A char literal, or a lifetime or label (left alone).
                if next == Some('\\') {
                    let end = chars[i + 2..]
                        .iter()
                        .position(|&c| c == '\'')
                        .map_or(chars.len(), |p| i + 3 + p);
                    i = end;
                } else if chars.get(i + 2) == Some(&'\'') {
                    i += 3;
                } else {
                    i += 1;
                }
                code_on_line = true;
                continue;
            }
            Syntax::Shell if c == '"' => (Some('"'), 1, false),
            Syntax::Shell if c == '\'' => (Some('\''), 1, true),
            Syntax::Hash if c == '"' || c == '\'' => {
                let tripled = next == Some(c) && chars.get(i + 2) == Some(&c);
                (Some(c), if tripled { 3 } else { 1 }, c == '\'')
            }
            _ => (None, 0, false),
        };
        if let Some(quote) = open {
            let mut region = Region::new(Kind::Literal, line);
            let mut j = i + close_len;
            loop {
                if j >= chars.len() {
                    break;
                }
                if chars[j] == '\\' && !raw {
                    if chars.get(j + 1) == Some(&'\n') {
                        line += 1;
                        region.push_line(line);
                    } else if let Some(&escaped) = chars.get(j + 1) {
                        region.text.push(escaped);
                    }
                    j += 2;
                    continue;
                }
                if chars[j] == quote
                    && (close_len == 1 || chars[j..].iter().take(3).all(|&c| c == quote))
                {
                    j += close_len;
                    break;
                }
                if chars[j] == '\n' {
                    line += 1;
                    region.push_line(line);
                } else {
                    region.text.push(chars[j]);
                }
                j += 1;
            }
            out.push(region);
            code_on_line = true;
            i = j;
            continue;
        }
        if !c.is_whitespace() {
            code_on_line = true;
        }
        i += 1;
    }
    out
}

/// The headings and bold paragraph leads of one Markdown file.
#[derive(Debug, Default)]
struct Sections {
    /// Heading texts, as written after the `#`s.
    headings: Vec<String>,
    /// `**Lead**` texts that open a line.
    leads: Vec<String>,
}

impl Sections {
    fn of(text: &str) -> Self {
        let mut sections = Sections::default();
        let mut fenced = false;
        for line in text.lines() {
            let line = line.trim_start();
            if line.starts_with("```") {
                fenced = !fenced;
                continue;
            }
            if fenced {
                continue;
            }
            if let Some(rest) = line.strip_prefix('#') {
                let rest = rest.trim_start_matches('#');
                if rest.starts_with(' ') {
                    sections.headings.push(rest.trim().to_owned());
                }
            } else if let Some(rest) = line.strip_prefix("**")
                && let Some(end) = rest.find("**")
            {
                sections.leads.push(rest[..end].to_owned());
            }
        }
        sections
    }

    /// A heading numbered `number` (`6`, `6.1`): its text starts with the number
    /// followed by `.`, a space or nothing.
    fn has_number(&self, number: &str) -> bool {
        self.headings.iter().any(|h| {
            h.strip_prefix(number)
                .is_some_and(|rest| rest.is_empty() || rest.starts_with(['.', ' ']))
        })
    }

    /// A heading or bold lead that starts with `title` (numbering, backticks,
    /// case and trailing punctuation aside).
    fn has_title(&self, title: &str) -> bool {
        let wanted = normalise_title(title);
        !wanted.is_empty()
            && self
                .headings
                .iter()
                .chain(&self.leads)
                .any(|h| normalise_title(h).starts_with(&wanted))
    }

    /// A heading whose GitHub anchor is `anchor`.
    fn has_anchor(&self, anchor: &str) -> bool {
        self.headings.iter().any(|h| github_anchor(h) == anchor)
    }
}

/// A title without its leading section number, backticks and closing
/// punctuation, in lower case.
fn normalise_title(title: &str) -> String {
    let t = title.trim();
    let t = t
        .trim_start_matches(|c: char| c.is_ascii_digit() || c == '.')
        .trim_start();
    t.replace('`', "")
        .trim_end_matches(['.', ':', ','])
        .to_lowercase()
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces as `-`.
fn github_anchor(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The resolving machinery: the root, its top-level directories, the regexes.
struct Checker {
    root: PathBuf,
    /// The root's directories (not hidden, not generated): a token starting with
    /// one of them is a repository path.
    top: BTreeSet<String>,
    /// The names of every directory of the repository: a prose token with a file
    /// extension starting with one of them is a repository path.
    dir_names: BTreeSet<String>,
    /// Every file and directory of the repository, relative to the root (`/`
    /// separators, directories with a trailing `/`): the paths a shortened
    /// reference may end.
    index: Vec<String>,
    path: Regex,
    link: Regex,
    section: Regex,
    title: Regex,
    more_title: Regex,
    upper: Regex,
}

impl Checker {
    fn new(root: &Path) -> Result<Self> {
        let mut top = BTreeSet::new();
        let entries =
            fs::read_dir(root).map_err(|e| format!("cannot list {}: {e}", root.display()))?;
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if entry.path().is_dir()
                && !name.starts_with('.')
                && !GENERATED.contains(&name.as_str())
            {
                top.insert(name);
            }
        }
        let mut index = Vec::new();
        let mut dir_names = BTreeSet::new();
        index_tree(root, root, &mut index, &mut dir_names)?;
        let regex = |r: &str| Regex::new(r).map_err(|e| format!("regex {r}: {e}"));
        Ok(Checker {
            root: root.to_owned(),
            top,
            dir_names,
            index,
            // A path-like token: optional ./ and ../, segments of name
            // characters, brace lists, globs and placeholders, an optional
            // trailing slash and #anchor.
            path: regex(
                r"(?:\.\.?/)*/?(?:[A-Za-z0-9_.*<>@+-]|\{[A-Za-z0-9_.,-]*\})+(?:/(?:[A-Za-z0-9_.*<>@+-]|\{[A-Za-z0-9_.,-]*\})+)*/?(?:#[A-Za-z0-9_-]+)?",
            )?,
            link: regex(r"\]\(([^)\s]+)\)")?,
            // §N, §N.M, §N-M, § N to §M.
            section: regex(r"§\s?(\d+(?:\.\d+)*)(?:\s?(?:-|–|to)\s?§?\s?(\d+(?:\.\d+)*))?")?,
            title: regex(r#"^`?(?:,|'s)?\s*"([^"]{2,120})""#)?,
            more_title: regex(r#"^(?:,\s*|\s+and\s+|\s+or\s+)"([^"]{2,120})""#)?,
            upper: regex(r"\b([A-Z][A-Z0-9_]{2,})\s?$")?,
        })
    }

    fn check_file(&self, file: &Path, text: &str, out: &mut Vec<Violation>) {
        let extension = file
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_default();
        let name = relative(&self.root, file);
        let dir = file.parent().unwrap_or(&self.root).to_owned();
        let package = package_dir(&self.root, &dir);
        let markdown = extension == "md";
        let context = Context {
            file,
            name: &name,
            dir: &dir,
            package: &package,
            markdown,
        };
        // The last Markdown file a comment cited: what a bare § refers to there.
        let mut last_cited: Option<PathBuf> = None;
        for region in regions(&extension, text) {
            if markdown {
                self.links(&context, &region, out);
            }
            self.paths(&context, &region, &mut last_cited, out);
            self.sections(&context, &region, &mut last_cited, out);
        }
    }

    /// Markdown link targets (`[text](target)`).
    fn links(&self, cx: &Context<'_>, region: &Region, out: &mut Vec<Violation>) {
        for capture in self.link.captures_iter(&region.text) {
            let target = capture.get(1).expect("group 1").as_str();
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let line = region.line_at(capture.get(0).expect("match").start());
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target, None),
            };
            let resolved = if path.is_empty() {
                Some(cx.file.to_owned())
            } else {
                match self.resolve_relative(&cx.dir.join(path)) {
                    Ok(p) if p.exists() => Some(p),
                    Ok(_) => {
                        out.push(cx.violation(line, target, MISSING));
                        None
                    }
                    Err(problem) => {
                        out.push(cx.violation(line, target, &problem));
                        None
                    }
                }
            };
            if let (Some(file), Some(anchor)) = (resolved, anchor)
                && !sections_of(&file).has_anchor(anchor)
            {
                out.push(cx.violation(line, target, "no heading with this anchor"));
            }
        }
    }

    /// Path tokens.
    fn paths(
        &self,
        cx: &Context<'_>,
        region: &Region,
        last_cited: &mut Option<PathBuf>,
        out: &mut Vec<Violation>,
    ) {
        let text = &region.text;
        for m in self.path.find_iter(text) {
            let before = text[..m.start()].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || "_/.:-\\$@{~".contains(c)) {
                continue;
            }
            let token = m.as_str().trim_end_matches(['.', ',', ':', ';']);
            let token = token.split('#').next().unwrap_or(token);
            if token.is_empty() || text[m.end()..].starts_with("://") {
                continue;
            }
            let line = region.line_at(m.start());
            match self.path_reference(cx, region.kind, token) {
                Reference::None => {}
                Reference::Found(file) => {
                    if file.extension().is_some_and(|e| e == "md") {
                        *last_cited = Some(file);
                    }
                }
                Reference::Missing(problem) => out.push(cx.violation(line, token, &problem)),
            }
        }
    }

    /// Whether `token` is a repository reference and whether it resolves.
    fn path_reference(&self, cx: &Context<'_>, kind: Kind, token: &str) -> Reference {
        let components: Vec<&str> = token.split('/').filter(|c| !c.is_empty()).collect();
        let Some(&last) = components.last() else {
            return Reference::None;
        };
        let placeholder = |c: &str, is_last: bool| {
            let stem = c.split('.').next().unwrap_or(c);
            let letters = stem.chars().filter(|c| c.is_alphabetic()).count();
            let upper = letters >= 2 && !stem.chars().any(|c| c.is_lowercase());
            c.contains(['<', '>'])
                || c.contains("{}")
                || c.contains("...")
                || c.starts_with('@')
                || GENERATED.contains(&c)
                || (upper && !(is_last && c.ends_with(".md")))
        };
        if components
            .iter()
            .enumerate()
            .any(|(i, c)| placeholder(c, i + 1 == components.len()))
            || (components.len() > 1 && last.starts_with('.') && last != "..")
        {
            return Reference::None;
        }
        let relative = token.starts_with("./") || token.starts_with("../");
        let has_slash = components.len() > 1 || token.ends_with('/') || relative;
        let first = components
            .iter()
            .find(|c| **c != "." && **c != "..")
            .copied()
            .unwrap_or("");
        let extension = last.rsplit_once('.').map(|(_, e)| e.trim_end_matches('}'));
        let file_like = extension.is_some_and(|e| {
            FILE_EXTENSIONS.contains(&e)
                || (last.contains('{') && FILE_EXTENSIONS.iter().any(|x| last.contains(x)))
        });
        let upper_doc = !has_slash
            && last.strip_suffix(".md").is_some_and(|stem| {
                !stem.is_empty()
                    && stem.chars().all(|c| {
                        c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_' || c == '-'
                    })
            });
        let prose = kind == Kind::Prose;
        if relative {
            // Relative to the citing file's directory or one of its ancestors
            // (a path relative to a package, or to the root): checked where it
            // names a repository directory, or in prose a file.
            if !(self.top.contains(first) || (prose && file_like)) {
                return Reference::None;
            }
            let candidates: Vec<PathBuf> = cx
                .dir
                .ancestors()
                .take_while(|a| a.starts_with(&self.root))
                .filter_map(|a| self.resolve_relative(&a.join(token)).ok())
                .collect();
            if candidates.is_empty() {
                return Reference::Missing("outside the repository".to_owned());
            }
            return self.exists_any(&candidates, None);
        }
        if token.starts_with('/') {
            return if token.starts_with("/work/") {
                Reference::Missing(
                    "an absolute path on the build machine, not in the repository".to_owned(),
                )
            } else {
                Reference::None
            };
        }
        if has_slash && self.top.contains(first) {
            return self.exists_any(&[self.root.join(token)], None);
        }
        if prose && ((has_slash && file_like && self.dir_names.contains(first)) || upper_doc) {
            let candidates = [
                self.root.join(token),
                cx.dir.join(token),
                cx.package.join(token),
            ];
            return self.exists_any(&candidates, Some(token));
        }
        Reference::None
    }

    /// `Found` with the first of `candidates` that exists (brace lists expanded,
    /// globs matched); else, with a `suffix`, the one repository path that ends
    /// with it; else `Missing`.
    fn exists_any(&self, candidates: &[PathBuf], suffix: Option<&str>) -> Reference {
        for candidate in candidates {
            let text = candidate.to_string_lossy();
            let expanded = expand_braces(&text);
            let all = expanded.iter().all(|p| {
                let path = Path::new(p);
                let found = if p.contains('*') {
                    glob_exists(path)
                } else {
                    path.exists()
                };
                found && (!p.ends_with('/') || path.is_dir())
            });
            if all {
                return Reference::Found(PathBuf::from(&expanded[0]));
            }
        }
        if let Some(suffix) = suffix
            && !suffix.contains(['*', '{'])
        {
            let wanted = format!("/{}", suffix.trim_start_matches("./"));
            let matches: Vec<&String> = self
                .index
                .iter()
                .filter(|p| {
                    format!("/{p}").ends_with(&wanted)
                        || format!("/{p}").ends_with(&format!("{wanted}/"))
                })
                .collect();
            match matches.as_slice() {
                [one] => return Reference::Found(self.root.join(one.as_str())),
                [] => {}
                several => {
                    let names: Vec<&str> = several.iter().map(|s| s.as_str()).collect();
                    return Reference::Missing(format!(
                        "ambiguous: the end of {}; give more of the path",
                        names.join(", ")
                    ));
                }
            }
        }
        Reference::Missing(MISSING.to_owned())
    }

    /// `path` with `.` and `..` resolved lexically; an error if it leaves the root.
    fn resolve_relative(&self, path: &Path) -> std::result::Result<PathBuf, String> {
        let mut out = PathBuf::new();
        for component in path.components() {
            match component {
                Component::CurDir => {}
                Component::ParentDir => {
                    if !out.pop() {
                        return Err("outside the repository".to_owned());
                    }
                }
                other => out.push(other),
            }
        }
        if out.starts_with(&self.root) {
            Ok(out)
        } else {
            Err("outside the repository".to_owned())
        }
    }

    /// Section references (`§`) and quoted titles after a Markdown file.
    fn sections(
        &self,
        cx: &Context<'_>,
        region: &Region,
        last_cited: &mut Option<PathBuf>,
        out: &mut Vec<Violation>,
    ) {
        let text = &region.text;
        // The file the previous § referred to, and where that reference ended:
        // a list (`§3, §4 and §5`) continues it.
        let mut previous: Option<(Option<PathBuf>, usize)> = None;
        for capture in self.section.captures_iter(text) {
            let whole = capture.get(0).expect("match");
            let line = region.line_at(whole.start());
            let before = text[..whole.start()].trim_end();
            let before = before
                .trim_end_matches('`')
                .trim_end_matches(',')
                .trim_end();
            let continued = previous.as_ref().is_some_and(|(_, end)| {
                let gap = text[*end..whole.start()].trim();
                gap.is_empty() || [",", "and", "or", "to", ";", "-", "–", ", and"].contains(&gap)
            });
            let file: Option<PathBuf> = if let Some(file) = self.md_before(cx, before) {
                match file {
                    Ok(path) => Some(path),
                    Err(token) => {
                        // The missing file itself is the path check's violation.
                        let _ = token;
                        previous = Some((None, whole.end()));
                        continue;
                    }
                }
            } else if let Some(name) = self.upper.captures(before).map(|c| c[1].to_owned()) {
                let doc = format!("{name}.md");
                match self.exists_any(
                    &[
                        self.root.join(&doc),
                        cx.dir.join(&doc),
                        cx.package.join(&doc),
                    ],
                    None,
                ) {
                    Reference::Found(path) => Some(path),
                    _ => {
                        out.push(cx.violation(
                            line,
                            &format!("{name} {}", whole.as_str()),
                            "no such document in the repository",
                        ));
                        previous = Some((None, whole.end()));
                        continue;
                    }
                }
            } else if continued {
                previous.as_ref().and_then(|(f, _)| f.clone())
            } else if cx.markdown {
                Some(cx.file.to_owned())
            } else if region.kind == Kind::Prose {
                match last_cited.clone() {
                    Some(path) => Some(path),
                    None => {
                        out.push(cx.violation(
                            line,
                            whole.as_str(),
                            "a section without a document: name the file before it",
                        ));
                        previous = Some((None, whole.end()));
                        continue;
                    }
                }
            } else {
                previous = Some((None, whole.end()));
                continue;
            };
            previous = Some((file.clone(), whole.end()));
            let Some(file) = file else { continue };
            if file.extension().is_some_and(|e| e == "md") && file != cx.file {
                *last_cited = Some(file.clone());
            }
            let sections = sections_of(&file);
            let shown = relative(&self.root, &file);
            for number in [capture.get(1), capture.get(2)].into_iter().flatten() {
                if !sections.has_number(number.as_str()) {
                    out.push(cx.violation(
                        line,
                        &format!("{shown} §{}", number.as_str()),
                        "no such numbered section",
                    ));
                }
            }
            // `§N "Title"`.
            if let Some(title) = self.title.captures(&text[whole.end()..]) {
                self.titles(cx, region, whole.end(), &file, title, out);
            }
        }
        // `file.md, "Title"`.
        for m in self.path.find_iter(text) {
            let token = m.as_str().trim_end_matches(['.', ',']);
            if !token.ends_with(".md") {
                continue;
            }
            let Some(title) = self.title.captures(&text[m.start() + token.len()..]) else {
                continue;
            };
            let Some(Ok(file)) = self.md_before(cx, &text[..m.start() + token.len()]) else {
                continue;
            };
            self.titles(cx, region, m.start() + token.len(), &file, title, out);
        }
    }

    /// Checks the quoted title captured after `offset` and those that continue
    /// it (`and "Other"`).
    fn titles(
        &self,
        cx: &Context<'_>,
        region: &Region,
        offset: usize,
        file: &Path,
        first: regex::Captures<'_>,
        out: &mut Vec<Violation>,
    ) {
        let sections = sections_of(file);
        let shown = relative(&self.root, file);
        let mut end = offset + first.get(0).expect("match").end();
        let mut titles = vec![(first[1].to_owned(), offset)];
        while let Some(more) = self.more_title.captures(&region.text[end..]) {
            titles.push((more[1].to_owned(), end));
            end += more.get(0).expect("match").end();
        }
        for (title, at) in titles {
            if !sections.has_title(&title) {
                out.push(cx.violation(
                    region.line_at(at),
                    &format!("{shown}, \"{title}\""),
                    "no heading or bold paragraph lead with this title",
                ));
            }
        }
    }

    /// The Markdown file that `before` ends with (a path token ending in `.md`,
    /// possibly in backticks): `Ok` with its path if it resolves, `Err` with the
    /// token if it does not, `None` if `before` does not end with one.
    fn md_before(
        &self,
        cx: &Context<'_>,
        before: &str,
    ) -> Option<std::result::Result<PathBuf, String>> {
        let before = before.trim_end_matches('`');
        if !before.ends_with(".md") {
            return None;
        }
        let token = self
            .path
            .find_iter(before)
            .filter(|m| m.end() == before.len())
            .last()?
            .as_str();
        let kind = Kind::Prose;
        match self.path_reference(cx, kind, token) {
            Reference::Found(path) => Some(Ok(path)),
            Reference::Missing(_) => Some(Err(token.to_owned())),
            Reference::None => {
                // A lower-case name without a directory: the citing file's
                // neighbour, else not a reference.
                let path = cx.dir.join(token);
                path.is_file().then_some(Ok(path))
            }
        }
    }
}

/// What a token turned out to be.
enum Reference {
    /// Not a repository reference.
    None,
    /// A reference to this existing file or directory.
    Found(PathBuf),
    /// A reference that does not resolve, and why.
    Missing(String),
}

/// The citing file's surroundings.
struct Context<'a> {
    file: &'a Path,
    name: &'a str,
    dir: &'a Path,
    package: &'a Path,
    markdown: bool,
}

impl Context<'_> {
    fn violation(&self, line: usize, reference: &str, problem: &str) -> Violation {
        Violation {
            file: self.name.to_owned(),
            line,
            reference: reference.to_owned(),
            problem: problem.to_owned(),
        }
    }
}

/// Every file and directory under `dir` (not the skipped directories) into
/// `index`, relative to `root`, and every directory's name into `names`.
fn index_tree(
    root: &Path,
    dir: &Path,
    index: &mut Vec<String>,
    names: &mut BTreeSet<String>,
) -> Result<()> {
    let entries = fs::read_dir(dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if SKIPPED_DIRS.contains(&name.as_str()) || name.starts_with('.') {
                continue;
            }
            index.push(format!("{}/", relative(root, &path)));
            names.insert(name);
            index_tree(root, &path, index, names)?;
        } else {
            index.push(relative(root, &path));
        }
    }
    Ok(())
}

/// The nearest directory from `dir` up to `root` with a `Cargo.toml` or a
/// `pyproject.toml` (the citing file's package), else `root`.
fn package_dir(root: &Path, dir: &Path) -> PathBuf {
    let mut current = dir;
    loop {
        if current.join("Cargo.toml").is_file() || current.join("pyproject.toml").is_file() {
            return current.to_owned();
        }
        match current.parent() {
            Some(parent) if current != root && parent.starts_with(root) => current = parent,
            _ => return root.to_owned(),
        }
    }
}

/// The sections of the Markdown file at `path` (none if it cannot be read).
fn sections_of(path: &Path) -> Sections {
    fs::read_to_string(path)
        .map(|t| Sections::of(&t))
        .unwrap_or_default()
}

/// `text` with its first `{a,b}` list expanded (recursively for the others).
fn expand_braces(text: &str) -> Vec<String> {
    let (Some(open), Some(close)) = (text.find('{'), text.find('}')) else {
        return vec![text.to_owned()];
    };
    if close < open {
        return vec![text.to_owned()];
    }
    text[open + 1..close]
        .split(',')
        .flat_map(|alternative| {
            expand_braces(&format!(
                "{}{alternative}{}",
                &text[..open],
                &text[close + 1..]
            ))
        })
        .collect()
}

/// Whether a path with `*` in its components matches an existing path.
fn glob_exists(path: &Path) -> bool {
    let mut current = vec![PathBuf::new()];
    for component in path.components() {
        let part = component.as_os_str().to_string_lossy();
        if part.contains('*') {
            let pattern: Vec<&str> = part.split('*').collect();
            let mut next = Vec::new();
            for dir in &current {
                let Ok(entries) = fs::read_dir(dir) else {
                    continue;
                };
                for entry in entries.flatten() {
                    let name = entry.file_name().to_string_lossy().into_owned();
                    if wildcard(&pattern, &name) {
                        next.push(dir.join(name));
                    }
                }
            }
            current = next;
        } else {
            current = current.into_iter().map(|d| d.join(&*part)).collect();
        }
    }
    current.iter().any(|p| p.exists())
}

/// `name` matches the `*`-separated `pattern` pieces.
fn wildcard(pattern: &[&str], name: &str) -> bool {
    let (Some(first), Some(last)) = (pattern.first(), pattern.last()) else {
        return true;
    };
    if !name.starts_with(first) || name.len() < first.len() + last.len() || !name.ends_with(last) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for piece in &pattern[1..pattern.len() - 1] {
        match rest.find(piece) {
            Some(i) => rest = &rest[i + piece.len()..],
            None => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .expect("the workspace root")
            .join(FIXTURE)
    }

    /// The fixture's good references pass; each bad one fails, once, with its
    /// line and its reason.
    #[test]
    fn the_fixture_fails_exactly_on_its_bad_references() {
        let (files, violations) = check_tree(&fixture(), &[]).unwrap();
        assert_eq!(files, 5, "{violations:#?}");
        let found: Vec<(String, usize, String)> = violations
            .iter()
            .map(|v| (v.file.clone(), v.line, v.reference.clone()))
            .collect();
        let expected: Vec<(String, usize, String)> = [
            ("bad.md", 3, "docs/missing.md"),
            ("bad.md", 4, "docs/guide.md §7"),
            ("bad.md", 5, "docs/guide.md, \"No such section\""),
            ("bad.md", 6, "docs/guide.md#nowhere"),
            ("bad.md", 7, "DESIGN.md"),
            ("bad.md", 8, "../shared/DESIGN.md"),
            ("bad.md", 9, "DESIGN §3"),
            ("bad.md", 10, "docs/guide.md §1.2"),
            ("bad.md", 12, "docs/guide.md, \"Gone\""),
            ("bad.md", 13, "/work/shared/TOOLCHAIN.md"),
            ("src/bad.rs", 2, "docs/guide.md §9"),
            ("src/bad.rs", 4, "docs/guide.md, \"Missing title\""),
            ("src/bad.rs", 6, "docs/nothing.rs"),
            ("src/bad.rs", 8, "src/nothing.rs"),
        ]
        .iter()
        .map(|(f, l, r)| (f.to_string(), *l, r.to_string()))
        .collect();
        assert_eq!(found, expected, "{violations:#?}");
    }

    #[test]
    fn regions_join_comment_lines_and_keep_strings_apart() {
        let text = "/// one `docs/a.md`, \"The\n/// title\"\nlet s = \"docs/b.md\"; // two\nlet c = '\"'; let r = r#\"x \" y\"#;\n";
        let regions = lex(text, Syntax::Rust);
        let texts: Vec<(&str, Kind)> = regions.iter().map(|r| (r.text.trim(), r.kind)).collect();
        assert_eq!(
            texts,
            vec![
                ("one `docs/a.md`, \"The title\"", Kind::Prose),
                ("docs/b.md", Kind::Literal),
                ("two", Kind::Prose),
                ("x \" y", Kind::Literal),
            ]
        );
        assert_eq!(
            regions[0].line_at(regions[0].text.find("title").unwrap()),
            2
        );
        let hash = lex("key = \"a # b\" # note\n'''x\ny'''\n", Syntax::Hash);
        let texts: Vec<&str> = hash.iter().map(|r| r.text.trim()).collect();
        assert_eq!(texts, vec!["a # b", "note", "x y"]);
    }

    #[test]
    fn anchors_numbers_and_titles() {
        let s = Sections::of(
            "# T\n## 6. Reduced `models`\n### 6.1 The embedded model\n**No panic in flight.** Text\n```\n## 9. Not a heading\n```\n",
        );
        assert!(
            s.has_number("6") && s.has_number("6.1") && !s.has_number("6.2") && !s.has_number("9")
        );
        assert!(
            s.has_title("Reduced models")
                && s.has_title("The embedded")
                && s.has_title("No panic in flight")
        );
        assert!(!s.has_title("Embedded"));
        assert!(s.has_anchor("6-reduced-models") && s.has_anchor("61-the-embedded-model"));
        assert_eq!(expand_braces("a.{png,svg}"), vec!["a.png", "a.svg"]);
        assert!(wildcard(&["memory-", ".x"], "memory-mps2.x") && !wildcard(&["a", "b"], "ba"));
    }
}
