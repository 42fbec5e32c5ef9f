//! `squeal report`: one self-contained HTML page for a study's last run, to send to a colleague
//! or keep beside a paper. Everything is inline (styles, the DAG as SVG, figures as PNG data),
//! so it opens anywhere without a network or a server.
//!
//! What it shows comes from the run's manifest (`OUT/manifest.parquet`: each instance's status,
//! reason, times, key, parameters and output digests) and the cache (the outputs themselves,
//! re-hashed on read): the DAG with each instance's status and wall time; per stage, its
//! instances with their swept parameters as columns, every figure, and its tables (a sweep's
//! points stacked with their parameters, long tables cut with a count, wide ones named with
//! their size; a table with an `unstable` column shows its unstable rows); and the provenance.

mod dag;

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;
use std::path::Path;

use base64::Engine;
use squeal_cache::{Cache, Digest};
use squeal_contract::{Artifact, ArtifactType, ColumnData, Coords, Table};

use crate::instances::Instances;
use crate::manifest::ManifestRow;
use crate::study::Study;

/// Rows of a table shown before it is cut.
const MAX_ROWS: usize = 15;
/// Columns of a table shown (scrolled sideways); wider tables are named with their size.
const MAX_COLUMNS: usize = 40;

/// What the report is made from.
pub struct ReportInput<'a> {
    pub study: &'a Study,
    /// Every stage's instances, as the study now expands.
    pub instances: &'a Instances,
    /// The last run's `manifest.parquet`.
    pub manifest: &'a [ManifestRow],
    pub cache: &'a Cache,
    pub study_bytes: &'a [u8],
    pub version: &'a str,
    pub out_dir: &'a Path,
}

/// One instance of the last run, as the manifest gives it.
pub struct InstanceView {
    pub name: String,
    stage_name: String,
    kind: String,
    pub status: String,
    pub reason: String,
    pub wall_s: Option<f64>,
    compute_s: Option<f64>,
    key: String,
    params_json: String,
    outputs: BTreeMap<String, Digest>,
    coords: Coords,
    /// The instance in the study as it now expands, if it still exists.
    instance: Option<usize>,
    /// Output folder relative to the report (`stage/mu=0.3`).
    folder: String,
}

/// The page.
pub fn render(input: &ReportInput) -> String {
    let views = instance_views(input);
    let index: HashMap<&str, usize> = views
        .iter()
        .enumerate()
        .map(|(idx, view)| (view.name.as_str(), idx))
        .collect();
    let edges: Vec<Vec<usize>> = views
        .iter()
        .map(|view| {
            let Some(instance) = view.instance.map(|idx| &input.instances.list[idx]) else {
                return Vec::new();
            };
            let mut ups: Vec<usize> = instance
                .inputs
                .iter()
                .flat_map(|input_| input_.from.iter())
                .filter_map(|up| index.get(input.instances.list[*up].name.as_str()).copied())
                .collect();
            ups.sort_unstable();
            ups.dedup();
            ups
        })
        .collect();

    let mut page = String::new();
    let study = input.study;
    let _ = write!(
        page,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{} — squeal report</title><style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        escape(&study.name),
        escape(&study.name)
    );
    if !study.description.is_empty() {
        let _ = writeln!(
            page,
            "<p class=\"description\">{}</p>",
            escape(&study.description)
        );
    }
    page.push_str(&summary(&views));
    page.push_str("<h2 id=\"dag\">Stages</h2>\n<div class=\"scroll\">");
    page.push_str(&dag::svg(&views, &edges));
    page.push_str("</div>\n<p class=\"legend\">");
    for status in ["ran", "cached", "failed", "skipped"] {
        let _ = write!(
            page,
            "<span style=\"background:{}\">{status}</span> ",
            dag::status_colour(status)
        );
    }
    page.push_str("</p>\n");

    let mut stage_order: Vec<&str> = Vec::new();
    for view in &views {
        if !stage_order.contains(&view.stage_name.as_str()) {
            stage_order.push(&view.stage_name);
        }
    }
    for stage_name in stage_order {
        let members: Vec<&InstanceView> = views
            .iter()
            .filter(|view| view.stage_name == stage_name)
            .collect();
        page.push_str(&stage_section(input, stage_name, &members));
    }
    page.push_str(&provenance(input, &views));
    page.push_str(CHECK_SCRIPT);
    page.push_str("</body></html>\n");
    page
}

fn instance_views(input: &ReportInput) -> Vec<InstanceView> {
    let by_name: HashMap<&str, usize> = input
        .instances
        .list
        .iter()
        .enumerate()
        .map(|(idx, instance)| (instance.name.as_str(), idx))
        .collect();
    input
        .manifest
        .iter()
        .map(|row| {
            let index = by_name.get(row.instance.as_str()).copied();
            let instance = index.map(|idx| &input.instances.list[idx]);
            let coords = instance.map_or_else(Vec::new, |instance| {
                input.instances.labelled(&instance.coords)
            });
            let folder = instance.map_or_else(
                || row.stage.clone(),
                |instance| {
                    std::iter::once(row.stage.clone())
                        .chain(input.instances.coord_segments(instance))
                        .collect::<Vec<_>>()
                        .join("/")
                },
            );
            let ran = matches!(row.status.as_str(), "ran" | "cached" | "failed");
            InstanceView {
                name: row.instance.clone(),
                stage_name: row.stage.clone(),
                kind: row.kind.clone(),
                status: row.status.clone(),
                reason: row.reason.clone(),
                wall_s: (row.status != "skipped").then_some(row.wall_s),
                compute_s: ran.then_some(row.compute_s),
                key: row.key.map(|key| key.hex()).unwrap_or_default(),
                params_json: row.params_json.clone(),
                outputs: row.outputs.clone(),
                coords,
                instance: index,
                folder,
            }
        })
        .collect()
}

fn summary(views: &[InstanceView]) -> String {
    let count = |status: &str| views.iter().filter(|view| view.status == status).count();
    let compute: f64 = views.iter().filter_map(|view| view.compute_s).sum();
    let mut text = format!(
        "<p class=\"summary\">{} instances: {} ran, {} cached, {} failed, {} skipped; {} of compute in all.</p>\n",
        views.len(),
        count("ran"),
        count("cached"),
        count("failed"),
        count("skipped"),
        dag::seconds(compute)
    );
    for view in views.iter().filter(|view| view.status == "failed") {
        let _ = writeln!(
            text,
            "<p class=\"failure\"><b>{}</b> {}</p>",
            escape(&view.name),
            escape(&view.reason)
        );
    }
    text
}

fn stage_section(input: &ReportInput, stage_name: &str, members: &[&InstanceView]) -> String {
    let first = members[0];
    let stage = input
        .study
        .index_of(stage_name)
        .map(|idx| &input.study.stages[idx].stage);
    let mut text = format!(
        "<section><h2 id=\"stage-{0}\">{0} <span class=\"kind\">{1}</span></h2>\n",
        escape(stage_name),
        escape(&first.kind)
    );
    if let Some(stage) = stage {
        let _ = writeln!(text, "<p class=\"doc\">{}</p>", escape(stage.doc()));
    }
    text.push_str(&instance_table(members));
    let Some(stage) = stage else {
        text.push_str(
            "<p>This stage is no longer in the study: its outputs are not shown.</p></section>\n",
        );
        return text;
    };
    for port in stage.outputs() {
        let present: Vec<(&InstanceView, Digest)> = members
            .iter()
            .filter_map(|view| view.outputs.get(port.name).map(|digest| (*view, *digest)))
            .collect();
        if present.is_empty() {
            continue;
        }
        match port.ty {
            ArtifactType::Figure => {
                for (view, digest) in &present {
                    text.push_str(&figure(input.cache, view, port.name, port.doc, digest));
                }
            }
            ArtifactType::Table => {
                text.push_str(&table_block(input.cache, &present, port.name, port.doc));
            }
            ArtifactType::Document => {
                let _ = write!(
                    text,
                    "<p class=\"document\"><b>{}</b>: {} (",
                    port.name,
                    escape(port.doc)
                );
                for (idx, (view, _)) in present.iter().enumerate() {
                    let separator = if idx == 0 { "" } else { ", " };
                    let _ = write!(
                        text,
                        "{separator}<code>{}/{}.*</code>",
                        escape(&view.folder),
                        port.name
                    );
                }
                text.push_str(")</p>\n");
            }
            _ => {}
        }
    }
    text.push_str("</section>\n");
    text
}

/// The stage's instances: swept parameters, status, times, why it ran, key and parameters.
fn instance_table(members: &[&InstanceView]) -> String {
    let labels: Vec<&str> = members[0]
        .coords
        .iter()
        .map(|(label, _)| label.as_str())
        .collect();
    let mut text = String::from("<table class=\"instances\"><tr>");
    for label in &labels {
        let _ = write!(text, "<th>{}</th>", escape(label));
    }
    text.push_str("<th>status</th><th>wall</th><th>compute</th><th>why it ran</th><th>key and parameters</th></tr>\n");
    for view in members {
        let _ = write!(text, "<tr class=\"{}\">", escape(&view.status));
        for (_, value) in &view.coords {
            let _ = write!(text, "<td>{}</td>", escape(&value.to_string()));
        }
        let time = |value: Option<f64>| value.map_or("—".to_string(), dag::seconds);
        let _ = writeln!(
            text,
            "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td><details><summary><code>{}</code></summary><code>{}</code></details></td></tr>",
            escape(&view.status),
            time(view.wall_s),
            time(view.compute_s),
            escape(&view.reason),
            escape(view.key.get(..12).unwrap_or(&view.key)),
            escape(&view.params_json)
        );
    }
    text.push_str("</table>\n");
    text
}

fn load(cache: &Cache, digest: &Digest) -> Result<Artifact, String> {
    let bytes = cache
        .get_object(digest)
        .map_err(|err| format!("not in the cache any more ({err}): rerun `squeal run`"))?;
    Artifact::decode(&bytes).map_err(|err| err.to_string())
}

fn figure(cache: &Cache, view: &InstanceView, name: &str, doc: &str, digest: &Digest) -> String {
    let caption = format!("{}/{name}.png — {doc}", view.folder);
    match load(cache, digest) {
        Ok(Artifact::Figure(figure)) => format!(
            "<figure><img class=\"figure\" alt=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{}</figcaption></figure>\n",
            escape(&format!("{} {name}", view.name)),
            base64::engine::general_purpose::STANDARD.encode(&figure.png),
            escape(&caption)
        ),
        Ok(_) => format!(
            "<p class=\"missing\">{}: not a figure</p>\n",
            escape(&caption)
        ),
        Err(message) => format!(
            "<p class=\"missing\">{}: {}</p>\n",
            escape(&caption),
            escape(&message)
        ),
    }
}

/// A table output: one table, or a sweep's points stacked with their parameters.
fn table_block(
    cache: &Cache,
    present: &[(&InstanceView, Digest)],
    name: &str,
    doc: &str,
) -> String {
    let mut loaded = Vec::with_capacity(present.len());
    for (view, digest) in present {
        match load(cache, digest) {
            Ok(Artifact::Table(table)) => loaded.push((view.coords.clone(), table)),
            Ok(_) => return String::new(),
            Err(message) => {
                return format!(
                    "<p class=\"missing\">{}/{name}: {}</p>\n",
                    escape(&view.folder),
                    escape(&message)
                );
            }
        }
    }
    let points: Vec<(Coords, &Table)> = loaded
        .iter()
        .map(|(coords, table)| (coords.clone(), table))
        .collect();
    let table = match Table::gather(&points) {
        Ok(table) => table,
        Err(err) => {
            return format!(
                "<p class=\"missing\">{name}: {}</p>\n",
                escape(&err.message)
            );
        }
    };
    let location = if present.len() == 1 {
        format!("{}/{name}.parquet", present[0].0.folder)
    } else {
        format!("{}/**/{name}.parquet", present[0].0.stage_name)
    };
    let mut text = format!(
        "<h3>{name}</h3><p class=\"doc\">{} — <code>{}</code></p>\n",
        escape(doc),
        escape(&location)
    );
    text.push_str(&html_table(&table));
    text
}

/// A table as HTML: the unstable rows of a table with an `unstable` column, the first
/// [`MAX_ROWS`] rows, or its size when it is wider than [`MAX_COLUMNS`] or a field over the
/// mesh (a `node`, `dof` or `row` column: mode shapes, snapshots, matrices).
fn html_table(table: &Table) -> String {
    let n_rows = table.n_rows();
    let per_dof = ["node", "dof", "row"]
        .iter()
        .any(|name| table.column(name).is_some());
    if table.columns().len() > MAX_COLUMNS || per_dof {
        let what = if per_dof {
            "a field over the mesh"
        } else {
            "too wide to show"
        };
        return format!(
            "<p class=\"wide\">{n_rows} rows × {} columns, {what}: read it with pandas, polars or duckdb.</p>\n",
            table.columns().len()
        );
    }
    let mut rows: Vec<usize> = (0..n_rows).collect();
    let mut note = String::new();
    if let Some(ColumnData::Bool(unstable)) = table.column("unstable") {
        rows.retain(|row| unstable[*row]);
        note = format!("{} unstable of {n_rows}", rows.len());
    }
    let shown = rows.len().min(MAX_ROWS);
    let mut text = String::from("<div class=\"scroll\"><table class=\"data\"><tr>");
    for column in table.columns() {
        let _ = write!(text, "<th>{}</th>", escape(&column.name));
    }
    text.push_str("</tr>\n");
    for &row in &rows[..shown] {
        text.push_str("<tr>");
        for column in table.columns() {
            let cell = match &column.data {
                ColumnData::F64(values) => number(values[row]),
                ColumnData::I64(values) => values[row].to_string(),
                ColumnData::Bool(values) => values[row].to_string(),
                ColumnData::Str(values) => escape(&values[row]),
            };
            let _ = write!(text, "<td>{cell}</td>");
        }
        text.push_str("</tr>\n");
    }
    text.push_str("</table></div>\n");
    if rows.len() > shown {
        let _ = write!(
            note,
            "{}{} more rows not shown",
            if note.is_empty() { "" } else { "; " },
            rows.len() - shown
        );
    }
    if !note.is_empty() {
        let _ = writeln!(text, "<p class=\"count\">{note}</p>");
    }
    text
}

/// Six significant digits, plain between 1e-3 and 1e6, in exponent form outside.
fn number(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return value.to_string();
    }
    let magnitude = value.abs().log10().floor();
    if (-3.0..6.0).contains(&magnitude) {
        let decimals = (5.0 - magnitude).max(0.0) as usize;
        let text = format!("{value:.decimals$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    } else {
        format!("{value:.5e}")
    }
}

fn provenance(input: &ReportInput, views: &[InstanceView]) -> String {
    let digest = Digest::of(input.study_bytes);
    let mut text =
        String::from("<h2 id=\"provenance\">Provenance</h2>\n<table class=\"provenance\">");
    for (label, value) in [
        ("squeal", input.version.to_string()),
        ("study file", input.study.file.clone()),
        ("study file blake3", digest.hex()),
        ("cache", input.cache.root().display().to_string()),
        ("outputs", input.out_dir.display().to_string()),
        ("instances", views.len().to_string()),
    ] {
        let _ = write!(
            text,
            "<tr><th>{label}</th><td><code>{}</code></td></tr>",
            escape(&value)
        );
    }
    text.push_str("</table>\n<p>Each instance's full cache key and parameters:</p>\n<table class=\"keys\"><tr><th>instance</th><th>key</th><th>parameters</th></tr>\n");
    for view in views {
        let _ = writeln!(
            text,
            "<tr><td>{}</td><td><code>{}</code></td><td><code>{}</code></td></tr>",
            escape(&view.name),
            escape(&view.key),
            escape(&view.params_json)
        );
    }
    text.push_str("</table>\n");
    text
}

/// Text for HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut escaped = String::with_capacity(text.len());
    for character in text.chars() {
        match character {
            '&' => escaped.push_str("&amp;"),
            '<' => escaped.push_str("&lt;"),
            '>' => escaped.push_str("&gt;"),
            '"' => escaped.push_str("&quot;"),
            '\'' => escaped.push_str("&#39;"),
            _ => escaped.push(character),
        }
    }
    escaped
}

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;color:#222}\
h1{margin-bottom:0.2em}h2{border-bottom:1px solid #ccc;margin-top:1.6em}.kind{font-weight:normal;color:#666;font-size:0.8em}\
.doc,.description{color:#444}.scroll{overflow-x:auto}table{border-collapse:collapse;margin:0.5em 0;font-size:0.85em}\
th,td{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top}th{background:#f2f2f2}\
tr.failed td{background:#fbe3e3}tr.skipped td{color:#888}.legend span{padding:2px 8px;border:1px solid #555;border-radius:3px}\
figure{margin:1em 0}img.figure{max-width:100%;border:1px solid #ddd}figcaption{font-size:0.85em;color:#555}\
.failure{background:#fbe3e3;padding:4px 8px}.missing{color:#a00}.count,.wide{font-size:0.85em;color:#555}\
details code{display:block;max-width:420px;white-space:pre-wrap;word-break:break-all}";

/// Marks on `<body>` how many figures decoded (`data-figures="7/7"`), which a headless browser
/// reads back; a figure that does not decode is outlined in red.
const CHECK_SCRIPT: &str = "<script>window.addEventListener('load',function(){\
var figures=document.querySelectorAll('img.figure');var shown=0;\
figures.forEach(function(img){if(img.complete&&img.naturalWidth>0){shown++;}else{img.style.outline='3px solid red';}});\
document.body.setAttribute('data-figures',shown+'/'+figures.length);});</script>\n";
