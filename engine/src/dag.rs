//! The study's DAG as Graphviz dot or Mermaid, one node per stage instance.

use crate::instances::Instances;
use crate::study::Study;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Dot,
    Mermaid,
}

pub fn render(study: &Study, instances: &Instances, format: Format) -> String {
    let node = |idx: usize| format!("n{idx}");
    let label = |idx: usize| {
        let instance = &instances.list[idx];
        format!(
            "{}\\n{}",
            instance.name,
            study.stages[instance.stage].stage.kind()
        )
    };
    let mut text = String::new();
    match format {
        Format::Dot => {
            text.push_str(&format!(
                "digraph \"{}\" {{\n  rankdir=LR;\n  node [shape=box];\n",
                study.name
            ));
            for idx in 0..instances.list.len() {
                text.push_str(&format!("  {} [label=\"{}\"];\n", node(idx), label(idx)));
            }
        }
        Format::Mermaid => {
            text.push_str("flowchart LR\n");
            for idx in 0..instances.list.len() {
                text.push_str(&format!(
                    "  {}[\"{}\"]\n",
                    node(idx),
                    label(idx).replace("\\n", "<br/>")
                ));
            }
        }
    }
    for (idx, instance) in instances.list.iter().enumerate() {
        for input in &instance.inputs {
            for &up in &input.from {
                let edge_label = format!("{} → {}", input.output, input.port);
                match format {
                    Format::Dot => text.push_str(&format!(
                        "  {} -> {} [label=\"{edge_label}\"];\n",
                        node(up),
                        node(idx)
                    )),
                    Format::Mermaid => {
                        text.push_str(&format!("  {} -->|{edge_label}| {}\n", node(up), node(idx)))
                    }
                }
            }
        }
    }
    if format == Format::Dot {
        text.push_str("}\n");
    }
    text
}
