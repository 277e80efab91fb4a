//! The published figures are generated, and stale ones fail the build: the measured figures of
//! README.md and the user guide (docs/guide/) come from docs/results/ through tools/figures.py
//! (tools/figures.toml names each one's file and expression), BENCHMARKS.md is assembled from
//! docs/results/h100/bench/ by tools/benchmarks-md.sh. (The guide's accuracy block has its own
//! check in tests/picture.rs.) The documents hold together: the book (docs/book.toml,
//! docs/SUMMARY.md) lists every guide page, every relative link and picture resolves, and every
//! repository path the documents name exists.

use crate::common;

use common::repo_path;
use std::process::Command;

#[test]
fn the_published_figures_are_current() {
    let run = Command::new("python3")
        .arg(repo_path("tools/figures.py"))
        .arg("--check")
        .output()
        .expect("python3 is needed (3.11 or newer) to check the published figures");
    assert!(
        run.status.success(),
        "figures in README.md or docs/guide/ differ from docs/results/ (run `python3 tools/figures.py`):\n{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn benchmarks_md_is_generated_from_the_committed_results() {
    let run = Command::new("bash")
        .arg(repo_path("tools/benchmarks-md.sh"))
        .arg(repo_path("docs/results/h100/bench"))
        .arg(env!("CARGO_BIN_EXE_vlf"))
        .arg(repo_path("docs/results/xr-h200"))
        .current_dir(repo_path("."))
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "tools/benchmarks-md.sh failed:\n{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let generated = String::from_utf8(run.stdout).unwrap();
    let committed = std::fs::read_to_string(repo_path("BENCHMARKS.md")).unwrap();
    if generated != committed {
        let out = std::env::temp_dir().join("BENCHMARKS.generated.md");
        std::fs::write(&out, &generated).unwrap();
        let first = generated
            .lines()
            .zip(committed.lines())
            .position(|(a, b)| a != b)
            .map_or(
                generated.lines().count().min(committed.lines().count()),
                |i| i,
            );
        panic!(
            "BENCHMARKS.md is not what tools/benchmarks-md.sh makes of docs/results/h100/bench/ \
             (first difference at line {}); the generated file is {}: \
             `bash tools/benchmarks-md.sh docs/results/h100/bench target/release/vlf > BENCHMARKS.md`",
            first + 1,
            out.display()
        );
    }
}

/// The picture manifest (docs/images/pictures.toml, tools/pictures.py): every picture the
/// documents show is listed with the command that makes it, no picture lies unused, and none
/// shows inputs that changed since it was made.
#[test]
fn every_picture_is_made_by_a_command_and_current() {
    let manifest: toml::Table =
        toml::from_str(&std::fs::read_to_string(repo_path("docs/images/pictures.toml")).unwrap())
            .expect("docs/images/pictures.toml parses");
    let pictures = manifest["pictures"].as_table().expect("a [pictures] table");
    let mut shown = std::collections::BTreeSet::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        // named from the root (docs/images/x.png) or, in the guide, relative (../images/x.png)
        let named = (text.match_indices("docs/images/").map(|(i, m)| i + m.len()))
            .chain(text.match_indices("../images/").map(|(i, m)| i + m.len()));
        for i in named {
            let name: String = text[i..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "-_.".contains(*c))
                .collect();
            if name.ends_with(".png") || name.ends_with(".jpg") {
                shown.insert((name, doc.display().to_string()));
            }
        }
    }
    let listed: Vec<&str> = (pictures.values())
        .map(|p| p["image"].as_str().expect("image is a file name"))
        .collect();
    for (image, doc) in &shown {
        assert!(
            listed.contains(&image.as_str()),
            "{doc} shows docs/images/{image}, which docs/images/pictures.toml does not list: add what makes it"
        );
    }
    for entry in std::fs::read_dir(repo_path("docs/images")).unwrap() {
        let file = entry.unwrap().file_name().to_string_lossy().to_string();
        assert!(
            file == "pictures.toml" || shown.iter().any(|(image, _)| *image == file),
            "docs/images/{file} is shown nowhere: remove it, or show it"
        );
    }
    let mut stale = Vec::new();
    for (name, p) in pictures {
        let image = p["image"].as_str().unwrap();
        assert!(
            repo_path("docs/images").join(image).is_file(),
            "docs/images/{image} ({name}) is missing"
        );
        let made_by = p["made_by"].as_str().unwrap();
        assert!(
            repo_path(made_by).is_file(),
            "{name}: made_by {made_by:?} is not a file of the repository"
        );
        let shows: Vec<&str> = (p["shows"].as_array().unwrap().iter())
            .map(|s| s.as_str().unwrap())
            .collect();
        let now = inputs_hash(&shows);
        let then = p.get("inputs_sha256").and_then(|h| h.as_str());
        if then != Some(now.as_str()) {
            let machine = p["machine"].as_str().unwrap();
            stale.push(format!(
                "  {image}: made by {made_by} ({machine}); it shows {shows:?}, changed since it was made"
            ));
        }
    }
    assert!(
        stale.is_empty(),
        "pictures older than what they show (regenerate each with its command, then stamp it: \
         `bash tools/pictures.sh target/release/vlf OUT NAME` and `python3 tools/pictures.py stamp OUT`, \
         or for pictures made by another script `python3 tools/pictures.py restamp NAME` once it ran):\n{}",
        stale.join("\n")
    );
}

/// The documents: whose pictures the manifest must list, whose links must resolve and whose
/// paths must exist (docs/ holds the book's SUMMARY.md, the guide and the results' notes).
fn documents() -> Vec<std::path::PathBuf> {
    let mut docs: Vec<_> = [
        "README.md",
        "BENCHMARKS.md",
        "ARCHITECTURE.md",
        "STABILITY.md",
    ]
    .iter()
    .map(|d| repo_path(d))
    .collect();
    docs.extend(markdown_under(&repo_path("docs")));
    docs
}

/// tools/pictures.py's `inputs_hash`: sha256 over the files below each path, in order; within a
/// folder sorted by relative path; each file's path ('/'-separated), a NUL, its bytes, a NUL.
fn inputs_hash(shows: &[&str]) -> String {
    use sha2::{Digest, Sha256};
    let root = repo_path(".");
    let mut hasher = Sha256::new();
    for entry in shows {
        let path = root.join(entry);
        let mut files = Vec::new();
        if path.is_dir() {
            collect_files(&path, &mut files);
        } else {
            assert!(
                path.is_file(),
                "{entry} (in a picture's `shows`) does not exist"
            );
            files.push(path);
        }
        let relative = |f: &std::path::Path| {
            let r = f.strip_prefix(&root).unwrap();
            (r.components())
                .map(|c| c.as_os_str().to_string_lossy().to_string())
                .collect::<Vec<_>>()
                .join("/")
        };
        files.sort_by_key(|f| relative(f));
        for f in files {
            hasher.update(relative(&f).as_bytes());
            hasher.update([0u8]);
            hasher.update(std::fs::read(&f).unwrap());
            hasher.update([0u8]);
        }
    }
    hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn collect_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            collect_files(&path, out);
        } else if path.is_file() {
            out.push(path);
        }
    }
}

/// The user guide is an mdBook (docs/book.toml, docs/SUMMARY.md, docs/guide/): every page
/// SUMMARY.md links exists, and every page of docs/guide/ is in SUMMARY.md. (CI does not build
/// the book: `cargo install mdbook && mdbook build docs` does, and needs exactly this.)
#[test]
fn the_book_lists_every_guide_page() {
    let book: toml::Table =
        toml::from_str(&std::fs::read_to_string(repo_path("docs/book.toml")).unwrap())
            .expect("docs/book.toml parses");
    let src = (book.get("book").and_then(|b| b.get("src")))
        .and_then(|s| s.as_str())
        .unwrap_or("src");
    let summary_path = repo_path("docs").join(src).join("SUMMARY.md");
    let summary = std::fs::read_to_string(&summary_path)
        .unwrap_or_else(|e| panic!("{}: {e}", summary_path.display()));
    let dir = summary_path.parent().unwrap();
    let mut listed = std::collections::BTreeSet::new();
    let mut missing = Vec::new();
    for (line, target) in links(&summary) {
        let file = dir.join(&target);
        if !file.is_file() {
            missing.push(format!("docs/SUMMARY.md:{line}: {target}"));
        }
        listed.insert(normalise(&file));
    }
    assert!(
        missing.is_empty(),
        "SUMMARY.md links pages that do not exist:\n{}",
        missing.join("\n")
    );
    let unlisted: Vec<String> = markdown_under(&repo_path("docs/guide"))
        .into_iter()
        .filter(|p| !listed.contains(&normalise(p)))
        .map(|p| relative(&p))
        .collect();
    assert!(
        unlisted.is_empty(),
        "guide pages that docs/SUMMARY.md does not list (the book would leave them out):\n{}",
        unlisted.join("\n")
    );
}

/// Every relative link and picture in README.md, ARCHITECTURE.md, BENCHMARKS.md, STABILITY.md and
/// the Markdown under docs/ (the book's SUMMARY.md, the guide) leads somewhere: the file (or folder) exists, and an `#anchor` into a Markdown file
/// names one of its headings (GitHub's anchors: lower case, punctuation dropped, spaces to '-').
#[test]
fn every_link_and_picture_resolves() {
    let mut broken = Vec::new();
    for doc in documents() {
        let text = std::fs::read_to_string(&doc).unwrap();
        for (line, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let file = match path {
                "" => doc.clone(),
                p => doc.parent().unwrap().join(p),
            };
            let at = format!("{}:{line}: {target}", relative(&doc));
            if !file.exists() {
                broken.push(format!("{at} (no such file)"));
            } else if !anchor.is_empty() && file.extension().is_some_and(|e| e == "md") {
                let headings = heading_anchors(&std::fs::read_to_string(&file).unwrap());
                if !headings.contains(anchor) {
                    broken.push(format!("{at} (no heading with that anchor)"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// Every repository path the documents name exists: in README.md, ARCHITECTURE.md,
/// BENCHMARKS.md, STABILITY.md and every Markdown file under docs/, each path under src/, shaders/, tests/,
/// tools/, config/, scenes/, docs/, fuzz/ or .ci/ (in prose, code or links; `<name>`, `{a,b}`,
/// `*` and upper-case placeholders such as NAME match any file), and each file named alone in
/// backticks (`post.rs`, `render.wgsl`, `figures.py`, `demo.sh`) somewhere in the tree.
#[test]
fn every_path_the_documents_name_exists() {
    let names = file_names(&repo_path("."));
    let mut missing = Vec::new();
    for doc in &documents() {
        let text = std::fs::read_to_string(doc).unwrap();
        for (line, path) in repository_paths(&text) {
            if !path_exists(&path) {
                missing.push(format!("{}:{line}: {path}", relative(doc)));
            }
        }
        for (line, name) in bare_file_names(&text) {
            if !names.contains(&name) {
                missing.push(format!(
                    "{}:{line}: `{name}` (no file of that name)",
                    relative(doc)
                ));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "the documents name paths that do not exist (fix the name, or the text):\n{}",
        missing.join("\n")
    );
}

fn markdown_under(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    collect_files(dir, &mut files);
    files.retain(|p| p.extension().is_some_and(|e| e == "md"));
    files.sort();
    files
}

fn relative(p: &std::path::Path) -> String {
    let root = repo_path(".");
    let n = normalise(p);
    (n.strip_prefix(normalise(&root)).unwrap_or(&n))
        .display()
        .to_string()
}

/// `a/b/../c` -> `a/c` (without touching the file system).
fn normalise(p: &std::path::Path) -> std::path::PathBuf {
    let mut out = std::path::PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// The text with fenced code blocks blanked (lines kept) and, outside them, inline code spans.
fn prose(text: &str) -> String {
    let mut out = String::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            out.push('\n');
            continue;
        }
        if !fenced {
            let mut in_code = false;
            for c in line.chars() {
                if c == '`' {
                    in_code = !in_code;
                }
                out.push(if in_code || c == '`' { ' ' } else { c });
            }
        }
        out.push('\n');
    }
    out
}

/// (line, target) of every inline link and picture, `[text](target)` and `![alt](target)`,
/// outside code.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in prose(text).lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let target = after[..end].split_whitespace().next().unwrap_or("");
            if !target.is_empty() {
                out.push((i + 1, target.to_string()));
            }
            rest = &after[end..];
        }
    }
    out
}

/// GitHub's anchor of every heading of a Markdown file.
fn heading_anchors(text: &str) -> std::collections::BTreeSet<String> {
    let mut fenced = false;
    let mut out = std::collections::BTreeSet::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced || !line.starts_with('#') {
            continue;
        }
        let title = line.trim_start_matches('#').trim();
        let anchor: String = (title.to_lowercase().chars())
            .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        out.insert(anchor);
    }
    out
}

/// The top-level folders whose paths the documents name.
const TREE: [&str; 9] = [
    "src/", "shaders/", "tests/", "tools/", "config/", "scenes/", "docs/", "fuzz/", ".ci/",
];

/// (line, path) of every path under one of TREE's folders, anywhere in the text.
fn repository_paths(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let bytes = line.as_bytes();
        let mut at = 0;
        while at < line.len() {
            let starts = (at == 0
                || !(bytes[at - 1].is_ascii_alphanumeric() || b"_/.-".contains(&bytes[at - 1])))
                && TREE.iter().any(|t| line[at..].starts_with(t));
            if !starts {
                at += line[at..].chars().next().unwrap().len_utf8();
                continue;
            }
            // a placeholder `<...>` or a group `{a,b}` is taken whole; a lone `>` ends the path
            let mut end = at;
            let mut closing = None;
            for c in line[at..].chars() {
                let ok = match (closing, c) {
                    (Some(close), c) => {
                        if c == close {
                            closing = None;
                        }
                        !c.is_whitespace()
                    }
                    (None, '<') => {
                        closing = Some('>');
                        true
                    }
                    (None, '{') => {
                        closing = Some('}');
                        true
                    }
                    (None, c) => c.is_ascii_alphanumeric() || "_.-*/".contains(c),
                };
                if !ok {
                    break;
                }
                end += c.len_utf8();
            }
            let path = line[at..end].trim_end_matches(['.', '-', ',']);
            out.push((i + 1, path.to_string()));
            at = end.max(at + 1);
        }
    }
    out
}

/// Whether a named path exists, placeholders matching any name: `<wall>`, `*`, `{a,b}` (each),
/// and an upper-case word (NAME, Q, DIR).
fn path_exists(path: &str) -> bool {
    if let (Some(open), Some(close)) = (path.find('{'), path.find('}')) {
        if open < close {
            return path[open + 1..close]
                .split(',')
                .all(|alt| path_exists(&format!("{}{alt}{}", &path[..open], &path[close + 1..])));
        }
    }
    let segments: Vec<&str> = path.split('/').filter(|s| !s.is_empty()).collect();
    fn walk(dir: &std::path::Path, segments: &[&str]) -> bool {
        let Some((first, rest)) = segments.split_first() else {
            return true;
        };
        let Ok(entries) = std::fs::read_dir(dir) else {
            return false;
        };
        entries.filter_map(|e| e.ok()).any(|e| {
            let name = e.file_name().to_string_lossy().to_string();
            glob(first, &name) && (rest.is_empty() || walk(&e.path(), rest))
        })
    }
    walk(&repo_path("."), &segments)
}

/// `pattern` (one path segment) against `name`: `*`, `<...>` and upper-case words match any run.
fn glob(pattern: &str, name: &str) -> bool {
    // the pattern as literal pieces between wildcards
    let mut pieces = vec![String::new()];
    let mut chars = pattern.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '*' || c == '<' {
            if c == '<' {
                for d in chars.by_ref() {
                    if d == '>' {
                        break;
                    }
                }
            }
            pieces.push(String::new());
        } else if c.is_ascii_uppercase() && pieces.last().unwrap().is_empty() {
            let mut word = c.to_string();
            while let Some(&d) = chars.peek() {
                if d.is_ascii_uppercase() || d.is_ascii_digit() || d == '_' {
                    word.push(d);
                    chars.next();
                } else {
                    break;
                }
            }
            // a placeholder is a whole word: NAME in NAME.patch, not README in README.md
            let whole = chars.peek().is_none_or(|d| !d.is_ascii_alphanumeric());
            if whole && !matches!(word.as_str(), "README" | "LICENSE" | "REDUCED") {
                pieces.push(String::new());
            } else {
                pieces.last_mut().unwrap().push_str(&word);
            }
        } else {
            pieces.last_mut().unwrap().push(c);
        }
    }
    if pieces.len() == 1 {
        return pieces[0] == name;
    }
    let (first, last) = (&pieces[0], pieces.last().unwrap());
    if !name.starts_with(first.as_str()) || !name[first.len()..].ends_with(last.as_str()) {
        return false;
    }
    let mut rest = &name[first.len()..name.len() - last.len()];
    for piece in &pieces[1..pieces.len() - 1] {
        match rest.find(piece.as_str()) {
            Some(i) => rest = &rest[i + piece.len()..],
            None => return false,
        }
    }
    true
}

/// (line, name) of each file named alone in inline code: `name.rs`, `.wgsl`, `.py`, `.sh`.
fn bare_file_names(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        }
        if fenced {
            continue;
        }
        for (k, span) in line.split('`').enumerate() {
            let named = k % 2 == 1
                && [".rs", ".wgsl", ".py", ".sh"]
                    .iter()
                    .any(|e| span.ends_with(e))
                && span
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
            if named {
                out.push((i + 1, span.to_string()));
            }
        }
    }
    out
}

/// The names of the repository's files (not its build output).
fn file_names(root: &std::path::Path) -> std::collections::BTreeSet<String> {
    let mut out = std::collections::BTreeSet::new();
    for entry in std::fs::read_dir(root).unwrap().filter_map(|e| e.ok()) {
        let name = entry.file_name().to_string_lossy().to_string();
        let path = entry.path();
        if path.is_dir() {
            if !matches!(name.as_str(), "target" | ".git" | "out" | "models" | "book") {
                out.extend(file_names(&path));
            }
        } else {
            out.insert(name);
        }
    }
    out
}
