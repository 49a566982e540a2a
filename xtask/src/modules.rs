//! The module graph of a crate, file by file, and its cycles (the layering
//! stage, [`crate::layering`]).
//!
//! The nodes are the crate's files: its root (`lib.rs` or `main.rs` in `src`, a
//! file of `src/bin`) and every file a `mod NAME;` brings in (`NAME.rs` or
//! `NAME/mod.rs` beside or below its parent). File `a` depends on file `b` when
//! `a`'s code names something of `b` through a path the compiler resolves
//! inside the crate: `crate::...`, `super::...`, `self::...`, or a path that
//! starts with one of its own child modules. A path is followed through the
//! modules it names and through the `use` declarations it meets (a
//! re-export, `pub use error::SimError` in the root, sends `crate::SimError`
//! on to `error.rs`), and stops at the file that holds the item. What the
//! compiler does not read is skipped: comments (doc links included), string
//! and character literals. A `pub use` (any visibility) is an alias that
//! others are resolved through, not a dependency of the file that declares it;
//! a private `use`, and every path in code, is one. `mod NAME;` itself is
//! structure, not a dependency. Inline modules (`mod tests { ... }`) are part
//! of their file: `super::*` in one names its own file.
//!
//! A cycle is a set of files that depend on each other in a ring: to
//! understand any of them one must read all of them. [`cycles`] lists each
//! ring (a strongly connected component of more than one file) once.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// One file of a crate's module tree.
#[derive(Debug)]
struct File {
    /// The file.
    path: PathBuf,
    /// Its module path from the crate root (`["sweep", "steady"]`; empty for
    /// the root).
    module: Vec<String>,
    /// Its tokens, comments and literals removed.
    tokens: Vec<Token>,
}

/// A token of Rust source, as far as paths need one.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Token {
    /// An identifier or keyword.
    Ident(String),
    /// `::`.
    PathSep,
    /// Any other punctuation character.
    Punct(char),
}

/// Where a path leads: a module of the crate (its path from the root), the
/// file that holds it, and the inline modules within that file.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Place {
    /// Index of the file.
    file: usize,
    /// The full module path (the file's module and inline modules in it).
    module: Vec<String>,
}

/// A crate's files, their modules, their `use` aliases and the dependencies
/// between them.
#[derive(Debug)]
pub struct Graph {
    files: Vec<File>,
    /// Module path → the file that holds it (inline modules: their file).
    modules: BTreeMap<Vec<String>, usize>,
    /// Module path → its `use` names → the absolute path each stands for.
    aliases: BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
    /// Module path → the modules it glob-imports or glob-re-exports (`use x::*`).
    globs: BTreeMap<Vec<String>, Vec<Vec<String>>>,
    /// Module path → the names of the items it defines.
    items: BTreeMap<Vec<String>, BTreeSet<String>>,
    /// For each file, the files it depends on.
    edges: Vec<BTreeSet<usize>>,
}

impl Graph {
    /// The graph of the crate whose root file is `root` (a package's `lib.rs`).
    pub fn of_crate(root: &Path) -> Result<Self, String> {
        let mut graph = Graph {
            files: Vec::new(),
            modules: BTreeMap::new(),
            aliases: BTreeMap::new(),
            globs: BTreeMap::new(),
            items: BTreeMap::new(),
            edges: Vec::new(),
        };
        graph.load(root.to_path_buf(), Vec::new(), true)?;
        for index in 0..graph.files.len() {
            graph.scan_declarations(index);
        }
        graph.edges = (0..graph.files.len())
            .map(|index| graph.dependencies(index))
            .collect();
        Ok(graph)
    }

    /// Reads `path` as module `module`, then every file module it declares.
    /// `owns_dir`: its children live in its own directory (a root or a
    /// `mod.rs`), else in the directory named after it.
    fn load(&mut self, path: PathBuf, module: Vec<String>, owns_dir: bool) -> Result<(), String> {
        let text = fs::read_to_string(&path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let tokens = tokenize(&text);
        let children = file_modules(&tokens);
        let index = self.files.len();
        self.modules.insert(module.clone(), index);
        self.files.push(File {
            path: path.clone(),
            module: module.clone(),
            tokens,
        });
        let dir = match (owns_dir, path.parent()) {
            (true, Some(parent)) => parent.to_path_buf(),
            (false, Some(parent)) => parent.join(
                path.file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default(),
            ),
            (_, None) => PathBuf::new(),
        };
        for (inline_path, name) in children {
            // A `mod NAME;` inside an inline module lives in the inline
            // module's directory.
            let mut child_dir = dir.clone();
            for segment in &inline_path {
                child_dir.push(segment);
            }
            let mut child = module.clone();
            child.extend(inline_path.iter().cloned());
            child.push(name.clone());
            let flat = child_dir.join(format!("{name}.rs"));
            let nested = child_dir.join(&name).join("mod.rs");
            if flat.is_file() {
                self.load(flat, child, false)?;
            } else if nested.is_file() {
                self.load(nested, child, true)?;
            } else {
                return Err(format!(
                    "{}: `mod {name};` has no file ({} or {})",
                    path.display(),
                    flat.display(),
                    nested.display()
                ));
            }
        }
        Ok(())
    }

    /// Records file `index`'s inline modules, the items each of its modules
    /// defines and its `use` aliases.
    fn scan_declarations(&mut self, index: usize) {
        let module = self.files[index].module.clone();
        let tokens = self.files[index].tokens.clone();
        let mut walker = Walker::new(&module);
        let mut i = 0;
        while i < tokens.len() {
            if let Some(next) = walker.enter_or_leave(&tokens, i) {
                if let Some(inline) = walker.opened() {
                    self.modules.insert(inline, index);
                }
                i = next;
                continue;
            }
            if walker.at_top()
                && let Token::Ident(keyword) = &tokens[i]
                && ITEM_KEYWORDS.contains(&keyword.as_str())
                && let Some(Token::Ident(name)) =
                    tokens.get(i + 1 + usize::from(keyword == "macro_rules"))
            {
                self.items
                    .entry(walker.current())
                    .or_default()
                    .insert(name.clone());
            }
            if tokens[i] == ident("use") {
                let (uses, end) = parse_use(&tokens, i + 1);
                let here = walker.current();
                for u in uses {
                    let Some(target) = absolute(&here, &u.path, &self.modules, &self.aliases)
                    else {
                        continue;
                    };
                    if u.glob {
                        self.globs.entry(here.clone()).or_default().push(target);
                    } else if let Some(name) = u.name {
                        self.aliases
                            .entry(here.clone())
                            .or_default()
                            .insert(name, target);
                    }
                }
                i = end;
                continue;
            }
            i += 1;
        }
    }

    /// The files file `index` depends on (itself excluded).
    fn dependencies(&self, index: usize) -> BTreeSet<usize> {
        let file = &self.files[index];
        let tokens = &file.tokens;
        let mut walker = Walker::new(&file.module);
        let mut found = BTreeSet::new();
        let mut i = 0;
        while i < tokens.len() {
            if let Some(next) = walker.enter_or_leave(tokens, i) {
                i = next;
                continue;
            }
            let here = walker.current();
            if tokens[i] == ident("use") {
                let public = is_public_before(tokens, i);
                let (uses, end) = parse_use(tokens, i + 1);
                if !public {
                    for u in uses {
                        if let Some(target) = absolute(&here, &u.path, &self.modules, &self.aliases)
                            && let Some(place) = self.resolve(&target, 0)
                        {
                            found.insert(place.file);
                        }
                    }
                }
                i = end;
                continue;
            }
            // A path in code: `crate::`, `super::`, `self::` or a child
            // module's name, not itself the tail of a longer path.
            if let Token::Ident(first) = &tokens[i]
                && tokens.get(i + 1) == Some(&Token::PathSep)
                && (i == 0 || tokens[i - 1] != Token::PathSep)
                && (matches!(first.as_str(), "crate" | "super" | "self") || {
                    let mut child = here.clone();
                    child.push(first.clone());
                    self.modules.contains_key(&child)
                        || self
                            .aliases
                            .get(&here)
                            .is_some_and(|a| a.contains_key(first))
                })
            {
                let (path, end) = read_path(tokens, i);
                if let Some(target) = absolute(&here, &path, &self.modules, &self.aliases)
                    && let Some(place) = self.resolve(&target, 0)
                {
                    found.insert(place.file);
                }
                i = end;
                continue;
            }
            i += 1;
        }
        found.remove(&index);
        found
    }

    /// Where the absolute path `path` leads: down the modules it names,
    /// through the aliases it meets, to the module holding its item.
    fn resolve(&self, path: &[String], depth: usize) -> Option<Place> {
        if depth > 32 {
            return None;
        }
        let mut module: Vec<String> = Vec::new();
        for (k, segment) in path.iter().enumerate() {
            let mut child = module.clone();
            child.push(segment.clone());
            if self.modules.contains_key(&child) {
                module = child;
                continue;
            }
            if let Some(target) = self.aliases.get(&module).and_then(|a| a.get(segment)) {
                let mut rest = target.clone();
                rest.extend(path[k + 1..].iter().cloned());
                return self.resolve(&rest, depth + 1);
            }
            if self.items.get(&module).is_some_and(|i| i.contains(segment)) {
                break;
            }
            // A name a glob brings in: from the first globbed module that has it.
            for glob in self.globs.get(&module).into_iter().flatten() {
                let mut child = glob.clone();
                child.push(segment.clone());
                let has = self.modules.contains_key(&child)
                    || self.items.get(glob).is_some_and(|i| i.contains(segment))
                    || self
                        .aliases
                        .get(glob)
                        .is_some_and(|a| a.contains_key(segment));
                if has && glob != &module {
                    let mut through = glob.clone();
                    through.extend(path[k..].iter().cloned());
                    return self.resolve(&through, depth + 1);
                }
            }
            break;
        }
        Some(Place {
            file: *self.modules.get(&module)?,
            module,
        })
    }

    /// Every cycle: each set of files (more than one) that depend on each
    /// other, as paths, sorted.
    pub fn cycles(&self) -> Vec<Vec<PathBuf>> {
        strongly_connected(&self.edges)
            .into_iter()
            .filter(|c| c.len() > 1)
            .map(|c| {
                let mut paths: Vec<PathBuf> =
                    c.iter().map(|&i| self.files[i].path.clone()).collect();
                paths.sort();
                paths
            })
            .collect()
    }

    /// The dependencies of each file, as paths (for messages and tests).
    #[cfg(test)]
    pub fn dependencies_of(&self, path: &Path) -> Vec<PathBuf> {
        self.files
            .iter()
            .position(|f| f.path == path)
            .map(|i| {
                self.edges[i]
                    .iter()
                    .map(|&j| self.files[j].path.clone())
                    .collect()
            })
            .unwrap_or_default()
    }
}

/// The crate roots under `dir` (a package directory): `lib.rs` and `main.rs`
/// in its `src`, and each `NAME.rs` and `NAME/main.rs` in `src/bin`.
pub fn crate_roots(dir: &Path) -> Vec<PathBuf> {
    let src = dir.join("src");
    let mut roots: Vec<PathBuf> = ["lib.rs", "main.rs"]
        .iter()
        .map(|f| src.join(f))
        .filter(|p| p.is_file())
        .collect();
    if let Ok(entries) = fs::read_dir(src.join("bin")) {
        let mut bins: Vec<PathBuf> = entries
            .flatten()
            .map(|e| e.path())
            .filter_map(|p| {
                if p.extension().is_some_and(|e| e == "rs") {
                    Some(p)
                } else if p.join("main.rs").is_file() {
                    Some(p.join("main.rs"))
                } else {
                    None
                }
            })
            .collect();
        bins.sort();
        roots.extend(bins);
    }
    roots
}

/// The keywords that define a named item (`macro_rules!` names its macro after the `!`).
const ITEM_KEYWORDS: &[&str] = &[
    "fn",
    "struct",
    "enum",
    "union",
    "trait",
    "type",
    "const",
    "static",
    "macro_rules",
];

fn ident(s: &str) -> Token {
    Token::Ident(s.to_owned())
}

/// Tracks the inline modules (`mod NAME { ... }`) around a position of a file.
struct Walker {
    /// The file's module path.
    base: Vec<String>,
    /// Open inline modules: name and the brace depth inside it.
    inline: Vec<(String, usize)>,
    /// Brace depth.
    depth: usize,
    /// The inline module opened by the last call, if any.
    just_opened: Option<Vec<String>>,
}

impl Walker {
    fn new(base: &[String]) -> Self {
        Walker {
            base: base.to_vec(),
            inline: Vec::new(),
            depth: 0,
            just_opened: None,
        }
    }

    /// The module at the position: the file's plus the open inline modules.
    fn current(&self) -> Vec<String> {
        let mut m = self.base.clone();
        m.extend(self.inline.iter().map(|(n, _)| n.clone()));
        m
    }

    /// Whether the position is at the top level of its module (not inside a
    /// function, an impl or any other braces).
    fn at_top(&self) -> bool {
        self.depth == self.inline.last().map_or(0, |(_, d)| *d)
    }

    /// The inline module the last [`Walker::enter_or_leave`] opened.
    fn opened(&mut self) -> Option<Vec<String>> {
        self.just_opened.take()
    }

    /// At `tokens[i]`: opens an inline module (`mod NAME {`), counts a brace,
    /// closes an inline module; returns where to go on, or None for any other
    /// token.
    fn enter_or_leave(&mut self, tokens: &[Token], i: usize) -> Option<usize> {
        self.just_opened = None;
        match &tokens[i] {
            Token::Ident(k) if k == "mod" => {
                if let (Some(Token::Ident(name)), Some(Token::Punct('{'))) =
                    (tokens.get(i + 1), tokens.get(i + 2))
                {
                    self.depth += 1;
                    self.inline.push((name.clone(), self.depth));
                    self.just_opened = Some(self.current());
                    return Some(i + 3);
                }
                None
            }
            Token::Punct('{') => {
                self.depth += 1;
                Some(i + 1)
            }
            Token::Punct('}') => {
                if self.inline.last().is_some_and(|(_, d)| *d == self.depth) {
                    self.inline.pop();
                }
                self.depth = self.depth.saturating_sub(1);
                Some(i + 1)
            }
            _ => None,
        }
    }
}

/// The file modules a file declares (`mod NAME;`), each with the inline
/// modules it is declared in.
fn file_modules(tokens: &[Token]) -> Vec<(Vec<String>, String)> {
    let mut walker = Walker::new(&[]);
    let mut found = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        if let Some(next) = walker.enter_or_leave(tokens, i) {
            i = next;
            continue;
        }
        if tokens[i] == ident("mod")
            && let (Some(Token::Ident(name)), Some(Token::Punct(';'))) =
                (tokens.get(i + 1), tokens.get(i + 2))
        {
            found.push((walker.current(), name.clone()));
            i += 3;
            continue;
        }
        i += 1;
    }
    found
}

/// Whether the `use` at `i` has a visibility (`pub`, `pub(crate)`, ...).
fn is_public_before(tokens: &[Token], i: usize) -> bool {
    match i.checked_sub(1).map(|k| &tokens[k]) {
        Some(Token::Ident(k)) if k == "pub" => true,
        Some(Token::Punct(')')) => {
            // `pub ( ... ) use`
            let mut k = i - 1;
            while k > 0 && tokens[k] != Token::Punct('(') {
                k -= 1;
            }
            k > 0 && tokens[k - 1] == ident("pub")
        }
        _ => false,
    }
}

/// One name a `use` declaration brings in.
#[derive(Debug, PartialEq)]
struct Use {
    /// The path as written (`["super", "data", "Data"]`).
    path: Vec<String>,
    /// The name it is known by here (None for a glob).
    name: Option<String>,
    /// `path::*`.
    glob: bool,
}

/// The names of the `use` tree starting at `tokens[i]`, and the index after
/// its `;`.
fn parse_use(tokens: &[Token], i: usize) -> (Vec<Use>, usize) {
    let mut uses = Vec::new();
    let end = use_tree(tokens, i, &[], &mut uses);
    let mut end = end;
    while end < tokens.len() && tokens[end] != Token::Punct(';') {
        end += 1;
    }
    (uses, end + 1)
}

/// One use tree (`a::b::{c, d::*}`, `e as f`) under `prefix`; returns the
/// index after it.
fn use_tree(tokens: &[Token], mut i: usize, prefix: &[String], uses: &mut Vec<Use>) -> usize {
    let mut path = prefix.to_vec();
    if tokens.get(i) == Some(&Token::PathSep) {
        i += 1;
    }
    loop {
        match tokens.get(i) {
            Some(Token::Ident(name)) => {
                path.push(name.clone());
                i += 1;
                if tokens.get(i) == Some(&Token::PathSep) {
                    i += 1;
                    continue;
                }
                // The end of a simple path, perhaps renamed.
                let mut local = name.clone();
                if tokens.get(i) == Some(&ident("as"))
                    && let Some(Token::Ident(alias)) = tokens.get(i + 1)
                {
                    local = alias.clone();
                    i += 2;
                }
                if local == "self" {
                    path.pop();
                    local = path.last().cloned().unwrap_or_default();
                } else if name == "self" {
                    path.pop();
                }
                uses.push(Use {
                    path,
                    name: Some(local),
                    glob: false,
                });
                return i;
            }
            Some(Token::Punct('*')) => {
                uses.push(Use {
                    path,
                    name: None,
                    glob: true,
                });
                return i + 1;
            }
            Some(Token::Punct('{')) => {
                i += 1;
                loop {
                    match tokens.get(i) {
                        Some(Token::Punct('}')) => return i + 1,
                        Some(Token::Punct(',')) => i += 1,
                        None => return i,
                        Some(_) => i = use_tree(tokens, i, &path, uses),
                    }
                }
            }
            _ => return i,
        }
    }
}

/// The path starting at `tokens[i]` (identifiers joined by `::`, generic
/// arguments cut off) and the index after it.
fn read_path(tokens: &[Token], mut i: usize) -> (Vec<String>, usize) {
    let mut path = Vec::new();
    while let Some(Token::Ident(name)) = tokens.get(i) {
        path.push(name.clone());
        i += 1;
        if tokens.get(i) == Some(&Token::PathSep)
            && matches!(tokens.get(i + 1), Some(Token::Ident(_)))
        {
            i += 1;
        } else {
            break;
        }
    }
    (path, i)
}

/// `path` as written in module `here`, made absolute from the crate root
/// (`crate::`, `super::`, `self::`, a child module of `here`, or a name `here`
/// imports, `aliases`); None for a path outside the crate (another crate,
/// `std`).
fn absolute(
    here: &[String],
    path: &[String],
    modules: &BTreeMap<Vec<String>, usize>,
    aliases: &BTreeMap<Vec<String>, BTreeMap<String, Vec<String>>>,
) -> Option<Vec<String>> {
    let first = path.first()?;
    match first.as_str() {
        "crate" => Some(path[1..].to_vec()),
        "self" => {
            let mut p = here.to_vec();
            p.extend(path[1..].iter().cloned());
            Some(p)
        }
        "super" => {
            let mut base = here.to_vec();
            let mut k = 0;
            while path.get(k).is_some_and(|s| s == "super") {
                base.pop()?;
                k += 1;
            }
            base.extend(path[k..].iter().cloned());
            Some(base)
        }
        name => {
            let mut child = here.to_vec();
            child.push(name.to_owned());
            if modules.contains_key(&child) {
                child.extend(path[1..].iter().cloned());
                Some(child)
            } else if let Some(target) = aliases.get(here).and_then(|a| a.get(name)) {
                let mut p = target.clone();
                p.extend(path[1..].iter().cloned());
                Some(p)
            } else {
                None
            }
        }
    }
}

/// Rust source as tokens, without comments, string, byte-string, raw-string
/// and character literals, numbers and lifetimes.
fn tokenize(text: &str) -> Vec<Token> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    let n = chars.len();
    while i < n {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c.is_whitespace() {
            i += 1;
        } else if c == '/' && next == Some('/') {
            while i < n && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < n {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if c == '"' {
            i = skip_string(&chars, i + 1);
        } else if (c == 'r' || (c == 'b' && next == Some('r')))
            && raw_string_start(&chars, i).is_some()
        {
            let (hashes, open) = raw_string_start(&chars, i).unwrap_or((0, i));
            i = skip_raw_string(&chars, open + 1, hashes);
        } else if c == 'b' && next == Some('"') {
            i = skip_string(&chars, i + 2);
        } else if c == 'b' && next == Some('\'') {
            i = skip_char(&chars, i + 1);
        } else if c == '\'' {
            // A character literal, or a lifetime / label.
            if next == Some('\\') || chars.get(i + 2) == Some(&'\'') {
                i = skip_char(&chars, i);
            } else {
                i += 1;
                while i < n && (chars[i].is_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
            }
        } else if c.is_ascii_digit() {
            while i < n && (chars[i].is_alphanumeric() || chars[i] == '_' || chars[i] == '.') {
                // `1..n`: a range, not a decimal point.
                if chars[i] == '.' && chars.get(i + 1) == Some(&'.') {
                    break;
                }
                i += 1;
            }
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < n && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            // A raw identifier `r#name` is the name.
            if word == "r" && chars.get(i) == Some(&'#') {
                i += 1;
                continue;
            }
            tokens.push(Token::Ident(word));
        } else if c == ':' && next == Some(':') {
            tokens.push(Token::PathSep);
            i += 2;
        } else {
            tokens.push(Token::Punct(c));
            i += 1;
        }
    }
    tokens
}

/// After the opening quote at `i`: the index after the closing one.
fn skip_string(chars: &[char], mut i: usize) -> usize {
    while i < chars.len() {
        match chars[i] {
            '\\' => i += 2,
            '"' => return i + 1,
            _ => i += 1,
        }
    }
    i
}

/// The number of `#` and the index of the opening quote of a raw string
/// starting at `i` (`r"`, `r#"`, `br##"`), if one starts there.
fn raw_string_start(chars: &[char], i: usize) -> Option<(usize, usize)> {
    let mut k = i + if chars[i] == 'b' { 2 } else { 1 };
    let mut hashes = 0;
    while chars.get(k) == Some(&'#') {
        hashes += 1;
        k += 1;
    }
    (chars.get(k) == Some(&'"')).then_some((hashes, k))
}

/// After a raw string's opening quote at `i`: the index after its end.
fn skip_raw_string(chars: &[char], mut i: usize, hashes: usize) -> usize {
    while i < chars.len() {
        if chars[i] == '"' && (1..=hashes).all(|h| chars.get(i + h) == Some(&'#')) {
            return i + 1 + hashes;
        }
        i += 1;
    }
    i
}

/// At the opening quote of a character literal: the index after it.
fn skip_char(chars: &[char], mut i: usize) -> usize {
    i += 1;
    while i < chars.len() {
        match chars[i] {
            '\\' => i += 2,
            '\'' => return i + 1,
            _ => i += 1,
        }
    }
    i
}

/// The strongly connected components of a graph given by its edges (Tarjan),
/// each as its nodes.
fn strongly_connected(edges: &[BTreeSet<usize>]) -> Vec<Vec<usize>> {
    struct State<'a> {
        edges: &'a [BTreeSet<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        components: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State<'_>, v: usize) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        for &w in s.edges[v].iter() {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(iw) if s.on_stack[w] => s.low[v] = s.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack[w] = false;
                component.push(w);
                if w == v {
                    break;
                }
            }
            s.components.push(component);
        }
    }
    let n = edges.len();
    let mut s = State {
        edges,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        components: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.components
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixture's crates, relative to the repository root.
    const FIXTURE: &str = "xtask/fixtures/modules";

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .parent()
            .unwrap()
            .join(FIXTURE)
            .join(name)
    }

    fn names(paths: &[PathBuf], base: &Path) -> Vec<String> {
        paths
            .iter()
            .map(|p| p.strip_prefix(base).unwrap().display().to_string())
            .collect()
    }

    /// The fixture with a ring of three files through `crate::`, `super::` and
    /// a re-export in the root: found, and only the ring's files.
    #[test]
    fn a_ring_of_files_is_one_cycle() {
        let dir = fixture("cycle");
        let graph = Graph::of_crate(&dir.join("src/lib.rs")).unwrap();
        let cycles = graph.cycles();
        assert_eq!(cycles.len(), 1, "{cycles:?}");
        assert_eq!(
            names(&cycles[0], &dir),
            ["src/net/mod.rs", "src/net/wire.rs", "src/store.rs"]
        );
    }

    /// The same shapes without the ring (a re-export is an alias, a doc link,
    /// a string and a test module's `super::*` no dependency): no cycle, and
    /// the dependencies are those of the code.
    #[test]
    fn aliases_comments_and_tests_make_no_cycle() {
        let dir = fixture("acyclic");
        let graph = Graph::of_crate(&dir.join("src/lib.rs")).unwrap();
        assert!(graph.cycles().is_empty(), "{:?}", graph.cycles());
        let deps = |f: &str| names(&graph.dependencies_of(&dir.join(f)), &dir);
        assert_eq!(deps("src/lib.rs"), Vec::<String>::new());
        assert_eq!(deps("src/error.rs"), Vec::<String>::new());
        assert_eq!(
            deps("src/run.rs"),
            ["src/error.rs", "src/plan/mod.rs", "src/plan/steps.rs"]
        );
        assert_eq!(deps("src/plan/mod.rs"), ["src/plan/steps.rs"]);
        assert_eq!(deps("src/plan/steps.rs"), ["src/error.rs"]);
    }

    #[test]
    fn tokens_skip_comments_and_literals() {
        let t = tokenize(
            "/* a /* nested */ crate::x */ let s = \"crate::y\"; let r = r#\"crate::z\"#; \
             let c = '\\''; fn f<'a>(x: &'a u8) {} // crate::w\nuse crate::v;",
        );
        let words: Vec<String> = t
            .iter()
            .filter_map(|t| match t {
                Token::Ident(w) => Some(w.clone()),
                _ => None,
            })
            .collect();
        assert_eq!(
            words,
            [
                "let", "s", "let", "r", "let", "c", "fn", "f", "x", "u8", "use", "crate", "v"
            ]
        );
    }

    #[test]
    fn use_trees_expand() {
        let t = tokenize("crate::a::{b, c::{self, d as e}, f::*};");
        let (uses, end) = parse_use(&t, 0);
        assert_eq!(end, t.len());
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(
            uses,
            [
                Use {
                    path: s(&["crate", "a", "b"]),
                    name: Some("b".into()),
                    glob: false
                },
                Use {
                    path: s(&["crate", "a", "c"]),
                    name: Some("c".into()),
                    glob: false
                },
                Use {
                    path: s(&["crate", "a", "c", "d"]),
                    name: Some("e".into()),
                    glob: false
                },
                Use {
                    path: s(&["crate", "a", "f"]),
                    name: None,
                    glob: true
                },
            ]
        );
    }
}
