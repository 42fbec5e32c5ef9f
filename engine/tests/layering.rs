//! No import circles between the files of a crate. Each `.rs` file under a crate's `src/` is a
//! node; an edge is a reference from one file to an item of another through `crate::…` (in a
//! `use` or inline) or through `super::…` where it reaches a file other than the referring
//! file's own ancestors (a sibling or a cousin; a child naming its parent is how a folder
//! module shares its helpers, and is not an edge). A path that ends at a name a module
//! re-exports (`crate::Table`, from `pub use table::Table` in `lib.rs`) reaches the file that
//! defines it. A cycle fails the test with each reference that closes it.
//!
//! One test per crate, so that each can be run alone: `cargo test -p squeal-engine --test
//! layering engine` or `… dynamics`. The engine's files are also held to its layers
//! ([`ENGINE_LAYERS`], the table of ARCHITECTURE.md): a file imports only from lower layers.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

#[test]
fn the_files_of_the_engine_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
}

#[test]
fn the_files_of_the_contract_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../contract/src"));
}

#[test]
fn the_files_of_the_fem_kernels_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../fem/src"));
}

#[test]
fn the_files_of_the_model_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/src"));
}

#[test]
fn the_files_of_the_dynamics_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../dynamics/src"));
}

#[test]
fn the_files_of_the_signal_stages_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../signal/src"));
}

#[test]
fn the_files_of_the_stages_registry_import_each_other_without_a_cycle() {
    assert_no_cycle(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../stages/src"));
}

/// The engine's layers, bottom up: a file (or a folder's files) imports only from files of a
/// lower layer, from the same folder, or as [`SAME_LAYER`] allows.
const ENGINE_LAYERS: &[&[&str]] = &[
    &[
        "spec.rs",
        "units.rs",
        "key.rs",
        "output.rs",
        "record.rs",
        "checkpoint.rs",
    ],
    &["ports.rs", "resources.rs"],
    &["study.rs"],
    &["instances.rs"],
    &["plan.rs"],
    &["outcome.rs", "manifest.rs"],
    &["run/"],
    &["dag.rs", "report/", "slurm/"],
    &["workbench.rs"],
    &["lib.rs"],
];

/// Imports within a layer: (from, to).
const SAME_LAYER: &[(&str, &str)] = &[
    ("units.rs", "spec.rs"),
    ("record.rs", "output.rs"),
    ("manifest.rs", "outcome.rs"),
];

#[test]
fn the_files_of_the_engine_import_only_from_lower_layers() {
    let graph = Graph::of_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let place = |file: usize| {
        let name = graph.name(file);
        ENGINE_LAYERS
            .iter()
            .enumerate()
            .find_map(|(layer, members)| {
                members
                    .iter()
                    .find(|member| {
                        name == **member || (member.ends_with('/') && name.starts_with(**member))
                    })
                    .map(|member| (layer, *member))
            })
            .unwrap_or_else(|| {
                panic!("{name} is in no layer: add it to ENGINE_LAYERS and ARCHITECTURE.md")
            })
    };
    let mut wrong = Vec::new();
    for (&(from, to), references) in &graph.edges {
        let ((from_layer, from_group), (to_layer, to_group)) = (place(from), place(to));
        let allowed = to_layer < from_layer
            || from_group == to_group
            || SAME_LAYER.contains(&(from_group, to_group));
        if !allowed {
            wrong.push(format!(
                "{} (layer {from_layer}) → {} (layer {to_layer}): line {}",
                graph.name(from),
                graph.name(to),
                references.join(", line ")
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layers:\n{}",
        wrong.join("\n")
    );
}

fn assert_no_cycle(src: &Path) {
    let graph = Graph::of_crate(src);
    let report = graph.cycles();
    assert!(
        report.components.is_empty(),
        "{}: {} between files, in {}:\n{}",
        src.display(),
        count(report.elementary, "import cycle"),
        count(report.components.len(), "group"),
        report.describe(&graph)
    );
}

/// `1 thing` or `n things`.
fn count(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// A `.rs` file's module path: `lib.rs` is `[]`, `a.rs` and `a/mod.rs` are `[a]`, `a/b.rs` is
/// `[a, b]`.
fn module_path(relative: &Path) -> Vec<String> {
    let mut parts: Vec<String> = relative
        .iter()
        .map(|part| part.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    if !matches!(last.as_str(), "lib.rs" | "main.rs" | "mod.rs") {
        parts.push(last.trim_end_matches(".rs").to_string());
    }
    parts
}

fn rust_files(dir: &Path, found: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|err| panic!("{}: {err}", dir.display()))
        .map(|entry| entry.expect("a directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, found);
        } else if path.extension().is_some_and(|ext| ext == "rs") {
            found.push(path);
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Ident(String),
    PathSep,
    Open(char),
    Close(char),
    Comma,
    Semi,
    Star,
    Lt,
    Dollar,
    Other,
}

/// The tokens of a Rust file that matter for paths, each with its line; comments, strings,
/// characters and lifetimes are dropped.
fn tokens(text: &str) -> Vec<(Token, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    let at = |i: usize| chars.get(i).copied().unwrap_or('\0');
    while i < chars.len() {
        let c = chars[i];
        if c == '\n' {
            line += 1;
            i += 1;
        } else if c.is_whitespace() {
            i += 1;
        } else if c == '/' && at(i + 1) == '/' {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            loop {
                if i >= chars.len() {
                    break;
                }
                if chars[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    line += usize::from(chars[i] == '\n');
                    i += 1;
                }
            }
        } else if c == '"' {
            i = skip_string(&chars, i, &mut line);
        } else if c == '\'' {
            if at(i + 1) == '\\' {
                // An escaped character: up to the closing quote.
                i += 2;
                while i < chars.len() && chars[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if at(i + 2) == '\'' {
                i += 3;
            } else {
                // A lifetime or a label.
                i += 1;
                while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
            }
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let word: String = chars[start..i].iter().collect();
            let raw_prefix = matches!(word.as_str(), "r" | "br" | "cr");
            if raw_prefix && (at(i) == '"' || (at(i) == '#' && matches!(at(i + 1), '"' | '#'))) {
                i = skip_raw_string(&chars, i, &mut line);
            } else if matches!(word.as_str(), "b" | "c") && at(i) == '"' {
                i = skip_string(&chars, i, &mut line);
            } else if word == "b" && at(i) == '\'' {
                i += 1;
                while i < chars.len() && chars[i] != '\'' {
                    i += if chars[i] == '\\' { 2 } else { 1 };
                }
                i += 1;
            } else if word == "r" && at(i) == '#' {
                // A raw identifier, `r#type`.
                i += 1;
                let start = i;
                while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                    i += 1;
                }
                out.push((Token::Ident(chars[start..i].iter().collect()), line));
            } else {
                out.push((Token::Ident(word), line));
            }
        } else if c.is_ascii_digit() {
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Token::Other, line));
        } else {
            let token = match c {
                ':' if at(i + 1) == ':' => {
                    i += 1;
                    Token::PathSep
                }
                '{' | '(' | '[' => Token::Open(c),
                '}' | ')' | ']' => Token::Close(c),
                ',' => Token::Comma,
                ';' => Token::Semi,
                '*' => Token::Star,
                '<' => Token::Lt,
                '$' => Token::Dollar,
                _ => Token::Other,
            };
            out.push((token, line));
            i += 1;
        }
    }
    out
}

/// Past the string that opens at `i` (a `"`), escapes included.
fn skip_string(chars: &[char], mut i: usize, line: &mut usize) -> usize {
    i += 1;
    while i < chars.len() && chars[i] != '"' {
        if chars[i] == '\\' {
            i += 1;
        }
        if chars.get(i) == Some(&'\n') {
            *line += 1;
        }
        i += 1;
    }
    i + 1
}

/// Past the raw string whose `#`s or `"` start at `i`.
fn skip_raw_string(chars: &[char], mut i: usize, line: &mut usize) -> usize {
    let mut hashes = 0;
    while chars.get(i) == Some(&'#') {
        hashes += 1;
        i += 1;
    }
    i += 1; // the opening quote
    while i < chars.len() {
        if chars[i] == '"' && (1..=hashes).all(|k| chars.get(i + k) == Some(&'#')) {
            return i + 1 + hashes;
        }
        *line += usize::from(chars[i] == '\n');
        i += 1;
    }
    i
}

/// A path as written, and how it starts.
#[derive(Debug, Clone)]
struct Written {
    segments: Vec<String>,
    line: usize,
    /// The module the path is written in (the file's, or an inline module's inside it).
    scope: Vec<String>,
}

/// What one file names: its `use` paths and inline `crate::`/`super::` paths, and the names
/// its top-level `use`s bind (for re-exports).
#[derive(Debug, Default)]
struct FileScan {
    paths: Vec<Written>,
    /// Name bound at the file's top level → the path it stands for.
    bindings: HashMap<String, Written>,
}

fn scan(text: &str, module: &[String]) -> FileScan {
    let tokens = tokens(text);
    let mut result = FileScan::default();
    let mut scope: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let mut pending_mod: Option<String> = None;
    let mut i = 0;
    let current = |scope: &[(String, usize)]| -> Vec<String> {
        module
            .iter()
            .cloned()
            .chain(scope.iter().map(|(name, _)| name.clone()))
            .collect()
    };
    while i < tokens.len() {
        let (token, line) = &tokens[i];
        match token {
            Token::Open('{') => {
                depth += 1;
                if let Some(name) = pending_mod.take() {
                    scope.push((name, depth));
                }
                i += 1;
            }
            Token::Close('}') => {
                if scope.last().is_some_and(|(_, at)| *at == depth) {
                    scope.pop();
                }
                depth -= 1;
                i += 1;
            }
            Token::Ident(word) if word == "mod" => {
                pending_mod = match (tokens.get(i + 1), tokens.get(i + 2)) {
                    (Some((Token::Ident(name), _)), Some((Token::Open('{'), _))) => {
                        Some(name.clone())
                    }
                    _ => None,
                };
                i += 1;
            }
            Token::Ident(word)
                if word == "use" && !matches!(tokens.get(i + 1), Some((Token::Lt, _))) =>
            {
                let mut trees = Vec::new();
                i = use_tree(&tokens, i + 1, Vec::new(), &mut trees);
                let here = current(&scope);
                for (segments, alias) in trees {
                    let written = Written {
                        segments,
                        line: *line,
                        scope: here.clone(),
                    };
                    if scope.is_empty()
                        && let Some(name) = alias
                    {
                        result.bindings.insert(name, written.clone());
                    }
                    result.paths.push(written);
                }
            }
            Token::Ident(word)
                if matches!(word.as_str(), "crate" | "super")
                    && matches!(tokens.get(i + 1), Some((Token::PathSep, _)))
                    && !matches!(
                        i.checked_sub(1).map(|j| &tokens[j].0),
                        Some(Token::PathSep | Token::Dollar)
                    ) =>
            {
                let mut segments = vec![word.clone()];
                let mut j = i + 1;
                while let (Some((Token::PathSep, _)), Some((Token::Ident(next), _))) =
                    (tokens.get(j), tokens.get(j + 1))
                {
                    segments.push(next.clone());
                    j += 2;
                }
                result.paths.push(Written {
                    segments,
                    line: *line,
                    scope: current(&scope),
                });
                i = j;
            }
            _ => i += 1,
        }
    }
    result
}

/// Parses the use tree starting at `i` under `prefix`; pushes each leaf (its path, and the
/// name it binds unless a glob) and returns the index after the tree (past a `;` at the top).
fn use_tree(
    tokens: &[(Token, usize)],
    mut i: usize,
    prefix: Vec<String>,
    out: &mut Vec<(Vec<String>, Option<String>)>,
) -> usize {
    let mut path = prefix;
    if matches!(tokens.get(i), Some((Token::PathSep, _))) {
        i += 1;
    }
    loop {
        match tokens.get(i).map(|(token, _)| token) {
            Some(Token::Ident(word)) => {
                path.push(word.clone());
                i += 1;
                match tokens.get(i).map(|(token, _)| token) {
                    Some(Token::PathSep) => i += 1,
                    Some(Token::Ident(kw)) if kw == "as" => {
                        let alias = match tokens.get(i + 1) {
                            Some((Token::Ident(alias), _)) if alias != "_" => Some(alias.clone()),
                            _ => None,
                        };
                        out.push((normalise(path), alias));
                        return end_of_tree(tokens, i + 2);
                    }
                    _ => {
                        let name = path.last().cloned();
                        let path = normalise(path);
                        let name = if name.as_deref() == Some("self") {
                            path.last().cloned()
                        } else {
                            name
                        };
                        out.push((path, name));
                        return end_of_tree(tokens, i);
                    }
                }
            }
            Some(Token::Star) => {
                out.push((normalise(path), None));
                return end_of_tree(tokens, i + 1);
            }
            Some(Token::Open('{')) => {
                i += 1;
                loop {
                    match tokens.get(i).map(|(token, _)| token) {
                        Some(Token::Close('}')) => {
                            i += 1;
                            break;
                        }
                        Some(Token::Comma) => i += 1,
                        None => return i,
                        _ => i = use_tree(tokens, i, path.clone(), out),
                    }
                }
                return end_of_tree(tokens, i);
            }
            _ => return end_of_tree(tokens, i),
        }
    }
}

/// Past a `;` ending a top-level tree; a nested tree stops before its `,` or `}`.
fn end_of_tree(tokens: &[(Token, usize)], i: usize) -> usize {
    match tokens.get(i) {
        Some((Token::Semi, _)) => i + 1,
        _ => i,
    }
}

/// `a::b::self` is `a::b`.
fn normalise(mut path: Vec<String>) -> Vec<String> {
    if path.last().is_some_and(|last| last == "self") && path.len() > 1 {
        path.pop();
    }
    path
}

/// How a reference reached its file.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Crate,
    Super,
    /// `self::…` or a relative path: not an edge.
    Local,
}

struct Graph {
    files: Vec<PathBuf>,
    modules: Vec<Vec<String>>,
    by_module: HashMap<Vec<String>, usize>,
    scans: Vec<FileScan>,
    /// (from, to) → the references, `line: path`.
    edges: BTreeMap<(usize, usize), Vec<String>>,
    src: PathBuf,
}

impl Graph {
    fn of_crate(src: &Path) -> Graph {
        let mut files = Vec::new();
        rust_files(src, &mut files);
        let modules: Vec<Vec<String>> = files
            .iter()
            .map(|file| module_path(file.strip_prefix(src).expect("under src")))
            .collect();
        let by_module = modules
            .iter()
            .enumerate()
            .map(|(idx, module)| (module.clone(), idx))
            .collect();
        let scans = files
            .iter()
            .zip(&modules)
            .map(|(file, module)| {
                let text = std::fs::read_to_string(file)
                    .unwrap_or_else(|err| panic!("{}: {err}", file.display()));
                scan(&text, module)
            })
            .collect();
        let mut graph = Graph {
            files,
            modules,
            by_module,
            scans,
            edges: BTreeMap::new(),
            src: src.to_path_buf(),
        };
        for from in 0..graph.files.len() {
            for written in &graph.scans[from].paths {
                let Some((to, kind)) = graph.resolve(written, 0) else {
                    continue;
                };
                let is_ancestor = graph.modules[from].starts_with(&graph.modules[to]);
                let counts = match kind {
                    Kind::Crate => true,
                    Kind::Super => !is_ancestor,
                    Kind::Local => false,
                };
                if counts && to != from {
                    graph.edges.entry((from, to)).or_default().push(format!(
                        "{}: {}",
                        written.line,
                        written.segments.join("::")
                    ));
                }
            }
        }
        graph
    }

    /// The absolute module path a written path names, and how it starts; `None` for another
    /// crate's path.
    fn absolute(&self, written: &Written) -> Option<(Vec<String>, Kind)> {
        let segments = &written.segments;
        match segments.first()?.as_str() {
            "crate" => Some((segments[1..].to_vec(), Kind::Crate)),
            "super" => {
                let ups = segments.iter().take_while(|s| *s == "super").count();
                let base = written.scope.len().checked_sub(ups)?;
                let mut path = written.scope[..base].to_vec();
                path.extend(segments[ups..].iter().cloned());
                Some((path, Kind::Super))
            }
            "self" => {
                let mut path = written.scope.clone();
                path.extend(segments[1..].iter().cloned());
                Some((path, Kind::Local))
            }
            first => {
                let mut child = written.scope.clone();
                child.push(first.to_string());
                self.by_module.contains_key(&child).then(|| {
                    let mut path = written.scope.clone();
                    path.extend(segments.iter().cloned());
                    (path, Kind::Local)
                })
            }
        }
    }

    /// The file that defines what `written` names.
    fn resolve(&self, written: &Written, hops: usize) -> Option<(usize, Kind)> {
        let (path, kind) = self.absolute(written)?;
        let file = self.file_of(&path, hops);
        Some((file, kind))
    }

    /// The file of the longest module prefix of `path`, following re-exports of the name after it.
    fn file_of(&self, path: &[String], hops: usize) -> usize {
        let mut prefix = path.len();
        let file = loop {
            if let Some(&file) = self.by_module.get(&path[..prefix]) {
                break file;
            }
            prefix -= 1;
        };
        let rest = &path[prefix..];
        if hops < 8
            && let Some(name) = rest.first()
            && let Some(binding) = self.scans[file].bindings.get(name)
            && let Some((target, _)) = self.absolute(binding)
        {
            let mut target = target;
            target.extend(rest[1..].iter().cloned());
            return self.file_of(&target, hops + 1);
        }
        file
    }

    fn name(&self, file: usize) -> String {
        self.files[file]
            .strip_prefix(&self.src)
            .expect("under src")
            .display()
            .to_string()
    }

    /// The strongly connected groups of more than one file (Tarjan), and the number of
    /// elementary cycles in them.
    fn cycles(&self) -> Cycles {
        let n = self.files.len();
        let mut next: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &(from, to) in self.edges.keys() {
            next[from].push(to);
        }
        let mut tarjan = Tarjan {
            next: &next,
            index: vec![None; n],
            low: vec![0; n],
            on_stack: vec![false; n],
            stack: Vec::new(),
            counter: 0,
            components: Vec::new(),
        };
        for node in 0..n {
            if tarjan.index[node].is_none() {
                tarjan.visit(node);
            }
        }
        let components: Vec<Vec<usize>> = tarjan
            .components
            .into_iter()
            .filter(|component| component.len() > 1)
            .map(|mut component| {
                component.sort_unstable();
                component
            })
            .collect();
        let mut elementary = 0;
        for component in &components {
            let members: BTreeSet<usize> = component.iter().copied().collect();
            for &start in component {
                // Cycles whose smallest member is `start`, each counted once.
                let mut path = vec![start];
                count_cycles(&next, &members, start, start, &mut path, &mut elementary);
            }
        }
        Cycles {
            components,
            elementary,
        }
    }
}

struct Tarjan<'a> {
    next: &'a [Vec<usize>],
    index: Vec<Option<usize>>,
    low: Vec<usize>,
    on_stack: Vec<bool>,
    stack: Vec<usize>,
    counter: usize,
    components: Vec<Vec<usize>>,
}

impl Tarjan<'_> {
    fn visit(&mut self, node: usize) {
        self.index[node] = Some(self.counter);
        self.low[node] = self.counter;
        self.counter += 1;
        self.stack.push(node);
        self.on_stack[node] = true;
        for &to in &self.next[node] {
            match self.index[to] {
                None => {
                    self.visit(to);
                    self.low[node] = self.low[node].min(self.low[to]);
                }
                Some(index) if self.on_stack[to] => self.low[node] = self.low[node].min(index),
                Some(_) => {}
            }
        }
        if Some(self.low[node]) == self.index[node] {
            let mut component = Vec::new();
            loop {
                let member = self.stack.pop().expect("on the stack");
                self.on_stack[member] = false;
                component.push(member);
                if member == node {
                    break;
                }
            }
            self.components.push(component);
        }
    }
}

/// Counts the simple paths from `at` back to `start` through members above `start`, up to a
/// bound that keeps a dense group from taking forever.
fn count_cycles(
    next: &[Vec<usize>],
    members: &BTreeSet<usize>,
    start: usize,
    at: usize,
    path: &mut Vec<usize>,
    count: &mut usize,
) {
    for &to in &next[at] {
        if *count >= 100_000 {
            return;
        }
        if to == start {
            *count += 1;
        } else if to > start && members.contains(&to) && !path.contains(&to) {
            path.push(to);
            count_cycles(next, members, start, to, path, count);
            path.pop();
        }
    }
}

struct Cycles {
    components: Vec<Vec<usize>>,
    elementary: usize,
}

impl Cycles {
    fn describe(&self, graph: &Graph) -> String {
        let mut text = String::new();
        for component in &self.components {
            let names: Vec<String> = component.iter().map(|&file| graph.name(file)).collect();
            text += &format!("- {}\n", names.join(", "));
            for (&(from, to), references) in &graph.edges {
                if component.contains(&from) && component.contains(&to) {
                    text += &format!(
                        "    {} → {}: line {}\n",
                        graph.name(from),
                        graph.name(to),
                        references.join(", line ")
                    );
                }
            }
        }
        text
    }
}

/// The scanner on small crates written for the purpose.
mod scanner {
    use super::*;

    fn crate_of(files: &[(&str, &str)]) -> (tempfile::TempDir, Graph) {
        let dir = tempfile::tempdir().expect("a temporary folder");
        for (name, text) in files {
            let path = dir.path().join(name);
            std::fs::create_dir_all(path.parent().expect("a folder")).expect("folders");
            std::fs::write(&path, text).expect("written");
        }
        let graph = Graph::of_crate(dir.path());
        (dir, graph)
    }

    fn edges(graph: &Graph) -> Vec<(String, String)> {
        graph
            .edges
            .keys()
            .map(|&(from, to)| (graph.name(from), graph.name(to)))
            .collect()
    }

    fn pair(from: &str, to: &str) -> (String, String) {
        (from.to_string(), to.to_string())
    }

    #[test]
    fn uses_inline_paths_and_re_exports_are_edges_and_comments_are_not() {
        let (_dir, graph) = crate_of(&[
            ("lib.rs", "mod a; mod b; mod c; pub use c::Thing;"),
            (
                "a.rs",
                "use crate::{b::{self, B}, Thing};\n// crate::c::Gone\nconst S: &str = \"crate::c::Gone\";",
            ),
            ("b.rs", "fn f() -> crate::c::C { C }"),
            (
                "c.rs",
                "pub struct Thing; pub struct C; fn g<'a>(x: &'a str) {}",
            ),
        ]);
        assert_eq!(
            edges(&graph),
            vec![
                pair("a.rs", "b.rs"),
                pair("a.rs", "c.rs"),
                pair("b.rs", "c.rs")
            ]
        );
        assert!(graph.cycles().components.is_empty());
    }

    #[test]
    fn a_sibling_through_super_is_an_edge_and_the_parent_is_not() {
        let (_dir, graph) = crate_of(&[
            ("lib.rs", "mod run;"),
            (
                "run/mod.rs",
                "mod execute; mod export; pub struct Executor;",
            ),
            (
                "run/execute.rs",
                "use super::Executor;\nuse super::export::write;",
            ),
            (
                "run/export.rs",
                "pub fn write() {}\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::execute::X;\n}",
            ),
        ]);
        assert_eq!(
            edges(&graph),
            vec![
                pair("run/execute.rs", "run/export.rs"),
                pair("run/export.rs", "run/execute.rs")
            ]
        );
        let cycles = graph.cycles();
        assert_eq!((cycles.components.len(), cycles.elementary), (1, 1));
    }

    #[test]
    fn a_cycle_is_found_and_named_with_its_references() {
        let (_dir, graph) = crate_of(&[
            ("lib.rs", "mod a; mod b; mod c;"),
            ("a.rs", "use crate::b::B;"),
            ("b.rs", "pub struct B(crate::c::C);"),
            ("c.rs", "pub struct C; use crate::a::A; use crate::b::B;"),
        ]);
        let cycles = graph.cycles();
        assert_eq!((cycles.components.len(), cycles.elementary), (1, 2));
        let text = cycles.describe(&graph);
        assert!(text.contains("c.rs → a.rs: line 1: crate::a::A"), "{text}");
    }
}
