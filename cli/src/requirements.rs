//! `pmacwd requirements`: the requirements matrix (`specs/requirements.yaml`) by manual page,
//! and its coverage figures.

use crate::common::{json_document, json_version, load_spec, Format};
use pmacwd_specs::requirements::{one_line, Category, Requirements, Statement};
use serde_json::json;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

pub fn requirements(format: Format, specs: Option<PathBuf>) -> ExitCode {
    let spec = match load_spec(&specs) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let m = &spec.requirements;
    match format {
        Format::Json => println!("{}", json_document("requirements", json_version::REQUIREMENTS, to_json(m))),
        Format::Text => print!("{}", to_text(m)),
    }
    ExitCode::SUCCESS
}

/// The statements grouped by page, pages in the order the file first names them.
fn by_page(m: &Requirements) -> Vec<(String, Vec<&Statement>)> {
    let mut pages: Vec<(String, Vec<&Statement>)> = Vec::new();
    for s in &m.statements {
        let page = s.page();
        match pages.iter_mut().find(|(p, _)| *p == page) {
            Some((_, list)) => list.push(s),
            None => pages.push((page, vec![s])),
        }
    }
    pages
}

fn figures(statements: &[&Statement]) -> String {
    Category::ALL
        .iter()
        .map(|c| format!("{} {}", statements.iter().filter(|s| s.category() == *c).count(), c.label()))
        .collect::<Vec<_>>()
        .join(", ")
}

fn to_text(m: &Requirements) -> String {
    let mut out = String::new();
    let all: Vec<&Statement> = m.statements.iter().collect();
    let _ = writeln!(out, "Requirements matrix (specs/requirements.yaml): {} statements", all.len());
    for c in Category::ALL {
        let _ = writeln!(out, "  {:<20} {:>4}", c.label(), m.count(c));
    }
    for (page, list) in by_page(m) {
        let _ = writeln!(
            out,
            "\n{page}: {} ({})",
            crate::common::plural(list.len() as u64, "statement", "statements"),
            figures(&list)
        );
        for s in list {
            let _ = writeln!(out, "  [{}] {}", s.category().key(), s.id);
            let _ = writeln!(out, "      {}", s.text());
            for r in &s.encoded_by {
                let _ = writeln!(out, "      {r}");
            }
            if let Some(d) = &s.deviation {
                let _ = writeln!(out, "      deviation: {}", one_line(&d.reason));
            }
            if let Some(n) = &s.note {
                let _ = writeln!(out, "      note: {}", one_line(n));
            }
        }
    }
    out
}

fn to_json(m: &Requirements) -> serde_json::Value {
    let coverage: serde_json::Map<String, serde_json::Value> =
        Category::ALL.iter().map(|c| (c.key().to_string(), json!(m.count(*c)))).collect();
    let pages: Vec<serde_json::Value> = by_page(m)
        .into_iter()
        .map(|(page, list)| {
            let statements: Vec<serde_json::Value> = list
                .iter()
                .map(|s| {
                    json!({
                        "id": s.id,
                        "quote": s.quote.as_deref().map(one_line),
                        "summary": s.summary.as_deref().map(one_line),
                        "category": s.category().key(),
                        "encoded_by": s.encoded_by.iter().map(|r| json!({"kind": r.kind(), "target": r.target()})).collect::<Vec<_>>(),
                        "deviation": s.deviation.as_ref().map(|d| one_line(&d.reason)),
                        "note": s.note.as_deref().map(one_line),
                    })
                })
                .collect();
            json!({"page": page, "statements": statements})
        })
        .collect();
    json!({"statements": m.statements.len(), "coverage": coverage, "pages": pages})
}
