//! The only module that parses YAML.
//!
//! serde_yaml is deprecated upstream; everything that touches it is here, so moving to a
//! maintained fork is a change to this file alone. Parsing is two passes over the text:
//!
//! 1. [`SourceMap::build`] walks the YAML events (yaml-rust2) and records the position of every
//!    key and sequence item under its dotted path (`words.X.bits.22`). It rejects duplicate
//!    mapping keys anywhere, at the position of the second occurrence: serde_yaml would keep
//!    only the last one when the target is a map, silently losing the first.
//! 2. serde_yaml deserializes into the typed schema with `deny_unknown_fields`; its errors
//!    (syntax, wrong type, unknown or missing key, a range check inside a `Deserialize` impl)
//!    carry their own position.
//!
//! Checks that look at more than one value (a duplicated name, a default outside its range)
//! run after both passes and use the source map to point at the offending key.

use crate::error::{Position, SpecError};
use serde::de::DeserializeOwned;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// Positions of every key and sequence item of one file, found by dotted path.
///
/// Stored as a tree (each node its own key and its parent), not as one full path per node, so
/// that memory is linear in the file's size however deep or wide it is.
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    file: PathBuf,
    /// (parent node, key or item index) -> (node, position). Node 0 is the document root.
    children: HashMap<(u32, Box<str>), (u32, Position)>,
    /// (sequence node, the scalar `id`, `name`, `command` or `number` of an item that is a
    /// mapping) -> the items so named, for [`SourceMap::has_path`].
    names: HashMap<(u32, Box<str>), Vec<u32>>,
}

/// The most nodes (scalars, mappings and sequences: keys, values and list items) one spec or
/// trace file may have. Memory grows with the nodes, not the bytes: each costs about 250 bytes
/// between the source map and serde_yaml's event list, so a flow collection written wide
/// (`[1,1,1,...]`, 2 bytes a node) took 130 times its size (a 16 MB file 2.1 GB, and a YAML
/// trace may have 64 MiB). The shipped files have at most a few thousand nodes; a longer trace
/// is JSON Lines, which is read a step at a time.
pub const NODES_MAX: usize = 250_000;

/// The keys that name a list item in a dotted path (`rules.counter_reset`).
const NAMING_KEYS: [&str; 4] = ["id", "name", "command", "number"];

thread_local! {
    /// YAML documents parsed on this thread, for the test that pins one parse per spec file.
    static DOCUMENTS_PARSED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
}

/// How many YAML documents this thread has parsed so far (every parse of a spec or trace file
/// goes through this module). Not part of the API: the loader's test compares two readings.
#[doc(hidden)]
pub fn documents_parsed() -> u64 {
    DOCUMENTS_PARSED.with(|c| c.get())
}

fn count_document() {
    DOCUMENTS_PARSED.with(|c| c.set(c.get() + 1));
}

/// The document root's node id.
const ROOT: u32 = 0;

impl SourceMap {
    /// Walks the events of `text`; fails on a syntax error or a duplicated mapping key.
    pub fn build(file: &Path, text: &str) -> Result<SourceMap, SpecError> {
        count_document();
        let mut walker = Walker {
            file: file.to_path_buf(),
            stack: Vec::new(),
            children: HashMap::new(),
            names: HashMap::new(),
            error: None,
            documents: 0,
            nodes: 0,
        };
        let mut parser = Parser::new_from_str(text);
        // All documents are walked, so that a second one is an error with its position.
        if let Err(e) = parser.load(&mut walker, true) {
            let m = e.marker();
            return Err(SpecError::at(file, within(text, position_of(m)), format!("YAML syntax: {}", e.info())));
        }
        if let Some(mut e) = walker.error {
            e.position = e.position.map(|p| within(text, p));
            return Err(e);
        }
        Ok(SourceMap { file: file.to_path_buf(), children: walker.children, names: walker.names })
    }

    /// A map of the top-level keys and items given, each at its position (`steps.3` at line
    /// 5), for a file whose form is not YAML (a JSON Lines trace: one step per line), so that
    /// what reads positions from a [`SourceMap`] works for it too. A dotted path given here
    /// is one node; a path below it is found at it, as [`SourceMap::position`] finds the
    /// nearest enclosing node.
    pub fn from_positions(file: &Path, positions: impl IntoIterator<Item = (String, Position)>) -> SourceMap {
        let mut children = HashMap::new();
        for (path, at) in positions {
            let mut node = ROOT;
            let parts: Vec<&str> = path.split('.').collect();
            for (depth, part) in parts.iter().enumerate() {
                let next = (children.len() + 1) as u32;
                let entry = children.entry((node, (*part).into())).or_insert((next, at));
                if depth + 1 == parts.len() {
                    entry.1 = at;
                }
                node = entry.0;
            }
        }
        SourceMap { file: file.to_path_buf(), children, names: HashMap::new() }
    }

    pub fn file(&self) -> &Path {
        &self.file
    }

    /// Position of the key or item at `path` (dotted, e.g. `profiles.um-215.readings`), or of
    /// the nearest enclosing node that has one, or the start of the file. A key that itself
    /// contains dots is found too: the longest run of components that names a key wins.
    pub fn position(&self, path: &str) -> Position {
        let parts: Vec<&str> = if path.is_empty() { Vec::new() } else { path.split('.').collect() };
        let mut node = ROOT;
        let mut found = Position { line: 1, column: 1 };
        let mut i = 0;
        'descend: while i < parts.len() {
            for j in (i + 1..=parts.len()).rev() {
                let key = parts[i..j].join(".");
                if let Some((child, pos)) = self.children.get(&(node, key.into_boxed_str())) {
                    node = *child;
                    found = *pos;
                    i = j;
                    continue 'descend;
                }
            }
            break;
        }
        found
    }

    /// Whether `path` (dotted) names a node of the file. In a mapping a component is a key (a
    /// key containing dots is found by its whole name); in a sequence it is an item whose `id`,
    /// `name`, `command` or `number` is the component, or the item's index. Resolved on this
    /// map, built by the one parse of the file: the requirements' 125 `spec` references used
    /// to parse their file again each (84% of every command's start-up).
    pub fn has_path(&self, path: &str) -> bool {
        fn below(map: &SourceMap, node: u32, parts: &[&str]) -> bool {
            if parts.is_empty() {
                return true;
            }
            let by_key = (1..=parts.len()).rev().any(|j| {
                let key = parts[..j].join(".");
                match map.children.get(&(node, key.into_boxed_str())) {
                    Some((child, _)) => below(map, *child, &parts[j..]),
                    None => false,
                }
            });
            by_key
                || map
                    .names
                    .get(&(node, parts[0].into()))
                    .is_some_and(|items| items.iter().any(|item| below(map, *item, &parts[1..])))
        }
        !path.is_empty() && below(self, ROOT, &path.split('.').collect::<Vec<_>>())
    }

    /// Sorts dotted paths into the order they appear in the file, so that "the second one"
    /// in an error message is the second one a reader meets.
    pub fn sort_by_position(&self, paths: &mut [String]) {
        paths.sort_by_key(|p| {
            let pos = self.position(p);
            (pos.line, pos.column)
        });
    }

    /// An error pointing at `path`.
    pub fn error(&self, path: &str, message: impl Into<String>) -> SpecError {
        SpecError::at(&self.file, self.position(path), message)
    }
}

fn position_of(m: &Marker) -> Position {
    // yaml-rust2 counts lines from 1 and columns from 0.
    Position { line: m.line(), column: m.col() + 1 }
}

/// `p`, or the end of `text` when `p` lies beyond it. At the end of a text without a final line
/// break the parsers report the start of the line after the last, which does not exist: an
/// editor asked to go there goes nowhere. Lines end as the YAML scanner ends them (`\r\n`,
/// `\r`, `\n`); columns count characters.
fn within(text: &str, p: Position) -> Position {
    let mut end = Position { line: 1, column: 1 };
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\r' || c == '\n' {
            if c == '\r' && chars.peek() == Some(&'\n') {
                chars.next();
            }
            end = Position { line: end.line + 1, column: 1 };
        } else {
            end.column += 1;
        }
    }
    if (p.line, p.column) > (end.line, end.column) {
        end
    } else {
        p
    }
}

enum Frame {
    /// `item_of`: the sequence this mapping is an item of; `naming`: the pending key is one of
    /// [`NAMING_KEYS`].
    Map {
        node: u32,
        key: Option<u32>,
        keys: HashSet<Box<str>>,
        item_of: Option<u32>,
        naming: bool,
    },
    Seq {
        node: u32,
        index: usize,
    },
}

struct Walker {
    file: PathBuf,
    stack: Vec<Frame>,
    children: HashMap<(u32, Box<str>), (u32, Position)>,
    names: HashMap<(u32, Box<str>), Vec<u32>>,
    error: Option<SpecError>,
    documents: u32,
    /// Nodes met so far, at most [`NODES_MAX`].
    nodes: usize,
}

impl Walker {
    fn add(&mut self, parent: u32, key: &str, pos: Position) -> u32 {
        // Ids count from 1; the root is 0. A file has far fewer than 2^32 nodes (the input is
        // bounded in bytes before it gets here).
        let id = u32::try_from(self.children.len() + 1).unwrap_or(u32::MAX);
        self.children.insert((parent, key.into()), (id, pos));
        id
    }

    /// Called for every node that is a value (scalar, alias or container start). Returns the
    /// node id of a value, or `None` when it is a mapping key (handled here).
    fn node(&mut self, scalar: Option<&str>, mark: Marker) -> Option<u32> {
        let pos = position_of(&mark);
        match self.stack.last_mut() {
            None => Some(ROOT),
            Some(Frame::Seq { node, index }) => {
                let (parent, i) = (*node, *index);
                *index += 1;
                Some(self.add(parent, &i.to_string(), pos))
            }
            Some(Frame::Map { node, key, keys, item_of, naming }) => match key.take() {
                Some(k) => {
                    if let (Some(seq), Some(name), true) = (*item_of, scalar, *naming) {
                        let item = *node;
                        self.names.entry((seq, name.into())).or_default().push(item);
                    }
                    Some(k)
                }
                None => {
                    let parent = *node;
                    let Some(k) = scalar else {
                        if self.error.is_none() {
                            self.error = Some(SpecError::at(&self.file, pos, "a mapping key must be a plain scalar"));
                        }
                        return None;
                    };
                    if !keys.insert(k.into()) && self.error.is_none() {
                        self.error = Some(SpecError::at(
                            &self.file,
                            pos,
                            format!("duplicate key `{k}` (an earlier entry has the same key)"),
                        ));
                    }
                    let id = self.add(parent, k, pos);
                    if let Some(Frame::Map { key, naming, .. }) = self.stack.last_mut() {
                        *key = Some(id);
                        *naming = NAMING_KEYS.contains(&k);
                    }
                    None
                }
            },
        }
    }
}

impl MarkedEventReceiver for Walker {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        if self.error.is_some() {
            return;
        }
        if matches!(ev, Event::Scalar(..) | Event::Alias(_) | Event::MappingStart(..) | Event::SequenceStart(..)) {
            self.nodes += 1;
            if self.nodes > NODES_MAX {
                self.error = Some(SpecError::at(
                    &self.file,
                    position_of(&mark),
                    format!(
                        "more than {NODES_MAX} YAML nodes (keys, values and list items), the most a spec or trace file \
                         may have: write a longer trace as JSON Lines"
                    ),
                ));
                return;
            }
        }
        match ev {
            Event::DocumentStart => {
                self.documents += 1;
                if self.documents > 1 {
                    self.error = Some(SpecError::at(
                        &self.file,
                        position_of(&mark),
                        "a second YAML document (after `---`): a spec or trace file holds exactly one",
                    ));
                }
            }
            Event::Scalar(value, ..) => {
                self.node(Some(&value), mark);
            }
            Event::Alias(_) => {
                // Aliases let a few lines expand into gigabytes (the "billion laughs"); no spec
                // or trace needs them, so they are refused where they appear.
                self.error = Some(SpecError::at(
                    &self.file,
                    position_of(&mark),
                    "YAML aliases (`*name`) are not supported in spec and trace files: write the value out",
                ));
            }
            Event::MappingStart(..) => {
                let item_of = match self.stack.last() {
                    Some(Frame::Seq { node, .. }) => Some(*node),
                    _ => None,
                };
                let node = self.node(None, mark).unwrap_or(ROOT);
                self.stack.push(Frame::Map { node, key: None, keys: HashSet::new(), item_of, naming: false });
            }
            Event::SequenceStart(..) => {
                let node = self.node(None, mark).unwrap_or(ROOT);
                self.stack.push(Frame::Seq { node, index: 0 });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
            }
            _ => {}
        }
    }
}

/// The nodes of `text` as [`NODES_MAX`] counts them (scalars, aliases, mappings and
/// sequences), or `None` when it is not YAML: for a writer that must stay within what the
/// readers take (`pmacwd import --yaml`).
pub fn node_count(text: &str) -> Option<usize> {
    struct Count(usize);
    impl MarkedEventReceiver for Count {
        fn on_event(&mut self, ev: Event, _: Marker) {
            if matches!(ev, Event::Scalar(..) | Event::Alias(_) | Event::MappingStart(..) | Event::SequenceStart(..)) {
                self.0 += 1;
            }
        }
    }
    let mut count = Count(0);
    Parser::new_from_str(text).load(&mut count, true).ok()?;
    Some(count.0)
}

/// Parses one file strictly into `T`, returning the source map for later checks.
pub fn parse<T: DeserializeOwned>(file: &Path, text: &str) -> Result<(T, SourceMap), SpecError> {
    let map = SourceMap::build(file, text)?;
    let value: T = serde_yaml::from_str(text).map_err(|e| match e.location() {
        Some(l) => {
            SpecError::at(file, within(text, Position { line: l.line(), column: l.column() }), strip_location(&e))
        }
        None => SpecError::whole_file(file, e.to_string()),
    })?;
    Ok((value, map))
}

/// serde_yaml appends " at line L column C" to its messages; we print the position up front.
fn strip_location(e: &serde_yaml::Error) -> String {
    let text = e.to_string();
    match text.rfind(" at line ") {
        Some(i) => text[..i].to_string(),
        None => text,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn has_path(text: &str, path: &str) -> bool {
        SourceMap::build(Path::new("t.yaml"), text).is_ok_and(|m| m.has_path(path))
    }

    #[test]
    fn has_path_finds_keys_list_items_by_id_and_keys_with_dots() {
        let text = "rules:\n  - id: a\n    x: 1\nbits:\n  22: {name: b}\nv:\n  1.947: {a: 1}\n";
        for p in ["rules", "rules.a", "rules.a.x", "rules.0", "bits.22", "bits.22.name", "v.1.947.a"] {
            assert!(has_path(text, p), "{p}");
        }
        for p in ["", "rule", "rules.b", "rules.a.y", "bits.21", "v.1", "bits.22.name.c"] {
            assert!(!has_path(text, p), "{p}");
        }
        assert!(!has_path("a: [", "a"));
        // Items named by each naming key, numbers too; a name nested deeper names nothing, and
        // neither does the value of a key that names nothing.
        let text = "l:\n  - name: n\n  - command: \"#1K\"\n  - number: 7\n  - {x: {id: deep}}\n  - other: o\n";
        for p in ["l.n", "l.#1K", "l.7", "l.3.x.id", "l.4.other"] {
            assert!(has_path(text, p), "{p}");
        }
        for p in ["l.deep", "l.o", "l.5"] {
            assert!(!has_path(text, p), "{p}");
        }
    }

    #[test]
    fn source_map_points_at_keys_and_items_with_one_based_positions() {
        let text = "a:\n  b: 1\n  list:\n    - x\n    - y\n";
        let map = SourceMap::build(Path::new("t.yaml"), text).unwrap();
        assert_eq!(map.position("a"), Position { line: 1, column: 1 });
        assert_eq!(map.position("a.b"), Position { line: 2, column: 3 });
        assert_eq!(map.position("a.list.1"), Position { line: 5, column: 7 });
        // Unknown paths fall back to the nearest known ancestor.
        assert_eq!(map.position("a.b.zzz"), Position { line: 2, column: 3 });
    }

    #[test]
    fn a_duplicated_mapping_key_is_reported_at_its_second_occurrence() {
        // serde_yaml alone would keep only the second `22:` when deserializing into a map.
        let text = "bits:\n  22: {name: a}\n  21: {name: b}\n  22: {name: c}\n";
        let err = SourceMap::build(Path::new("s.yaml"), text).unwrap_err();
        assert_eq!(err.position, Some(Position { line: 4, column: 3 }));
        assert!(err.message.contains("duplicate key `22`"), "{}", err.message);
    }

    #[test]
    fn serde_errors_keep_their_position_without_repeating_it() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct T {
            name: String,
        }
        let err = parse::<T>(Path::new("t.yaml"), "\nnmae: x\n").unwrap_err();
        assert_eq!(err.position, Some(Position { line: 2, column: 1 }));
        assert!(err.message.contains("unknown field `nmae`"), "{}", err.message);
        assert!(!err.message.contains(" at line "), "{}", err.message);
    }

    #[test]
    fn the_source_map_grows_with_the_file_not_with_the_depth_of_its_keys() {
        // A long key with many children used to be stored once per child, inside every child's
        // full path: a 200 KB file took 1 GB. Each node now keeps only its own key.
        let long_key = "k".repeat(100_000);
        // An explicit key (`? key`), since plain keys stop at 1,024 characters.
        let mut text = format!("? {long_key}\n:\n");
        for i in 0..10_000 {
            text.push_str(&format!("  c{i}: 1\n"));
        }
        let map = SourceMap::build(Path::new("wide.yaml"), &text).unwrap();
        let stored: usize = map.children.keys().map(|(_, k)| k.len()).sum();
        assert!(stored <= text.len(), "{stored} key bytes kept for a {}-byte file", text.len());
        assert_eq!(map.position(&format!("{long_key}.c9999")), Position { line: 10_002, column: 3 });
    }

    #[test]
    fn a_file_past_the_node_limit_is_refused_at_the_first_node_beyond_it() {
        // Issue 33: a flow collection written wide (`[1,1,1,...]`, 2 bytes a node) took 130
        // times its size in memory (4 MB: 538 MB), whatever the file was for. The walk now
        // stops at the first node past NODES_MAX, before serde_yaml holds any of it.
        let wide = |items: usize| format!("a: 1\nb: [{}1]\n", "1,".repeat(items - 1));
        // `a`, 1, `b`, the sequence: 4 nodes besides the items; the root mapping is the 5th.
        let at_limit = wide(NODES_MAX - 5);
        assert!(SourceMap::build(Path::new("w.yaml"), &at_limit).is_ok());
        let e = SourceMap::build(Path::new("w.yaml"), &wide(NODES_MAX - 4)).unwrap_err();
        let column = 5 + 2 * (NODES_MAX - 5);
        assert_eq!(e.position, Some(Position { line: 2, column }), "{e}");
        assert!(e.message.contains(&format!("more than {NODES_MAX} YAML nodes")), "{e}");
        // parse refuses it before deserializing.
        let e = parse::<serde_yaml::Value>(Path::new("w.yaml"), &wide(3 * NODES_MAX)).unwrap_err();
        assert_eq!(e.position, Some(Position { line: 2, column }), "{e}");
    }

    #[test]
    fn a_key_with_dots_is_found_by_its_whole_name() {
        let map = SourceMap::build(Path::new("t.yaml"), "versions:\n  1.947: {a: 1}\n").unwrap();
        assert_eq!(map.position("versions.1.947.a"), Position { line: 2, column: 11 });
    }

    #[test]
    fn a_syntax_error_at_the_end_of_a_file_without_a_final_line_break_points_at_its_last_line() {
        // Found by the fuzz target yaml_trace: the parser reported line 8 of this 7-line trace,
        // a line that does not exist. It is now the end of the last line.
        let text = "version: 1\ndescription: >\n  PLC 0 taking all the CPU the servo leaves starves the \
                    background, which never gets to reset\n  the counter: the watchdog trips exactly as if the \
                    background had stopped.\ncite: [UM p.236, SRM p.42]\nconfiguration: i40-zero\n\
                    profiles: [umhe model refuses i";
        let e = SourceMap::build(Path::new("t.yaml"), text).unwrap_err();
        assert_eq!(e.position, Some(Position { line: 7, column: 32 }), "{e}");
        // The same with other line ends, and an error inside the text keeps its position.
        for (text, at) in [
            ("a: [x", (1, 6)),
            ("a: 1\r\nb: [x", (2, 6)),
            ("a: 1\rb: [x", (2, 6)),
            ("a: [x\n", (2, 1)),
            ("a: \"x", (1, 4)),
        ] {
            let e = SourceMap::build(Path::new("t.yaml"), text).unwrap_err();
            assert_eq!(e.position.map(|p| (p.line, p.column)), Some(at), "{text:?}: {e}");
        }
    }

    #[test]
    fn a_duplicated_empty_key_at_the_end_of_a_file_is_reported_inside_the_file() {
        // Found by the fuzz target yaml_trace: two empty explicit keys (`?`); the parser marks
        // the second at the end of the stream, which was reported as line 6 of a 5-line file.
        let e = SourceMap::build(Path::new("t.yaml"), "?\n\n?\n\n#\0\0\0\0\0\0\0c").unwrap_err();
        assert!(e.message.contains("duplicate key ``"), "{e}");
        assert_eq!(e.position, Some(Position { line: 5, column: 10 }), "{e}");
    }

    #[test]
    fn aliases_and_second_documents_are_refused_where_they_appear() {
        // An alias bomb used to stop inside serde_yaml with "repetition limit exceeded" and no
        // position; a second document with no position at all.
        let e = SourceMap::build(Path::new("t.yaml"), "a: &x [1, 2]\nb: [*x, *x]\n").unwrap_err();
        assert_eq!(e.position, Some(Position { line: 2, column: 5 }));
        assert!(e.message.contains("aliases"), "{}", e.message);
        let e = SourceMap::build(Path::new("t.yaml"), "a: 1\n---\na: 2\n").unwrap_err();
        assert_eq!(e.position.map(|p| p.line), Some(2), "{e:?}");
        assert!(e.message.contains("second YAML document"), "{}", e.message);
    }
}
