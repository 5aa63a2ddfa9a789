//! No module cycles: inside every crate of the workspace, "module A names an item that module B
//! defines" must form no cycle, so each module can be read (and moved) after the ones it uses.
//!
//! How it is checked: each crate's module tree is followed from its root through `mod name;`
//! (`#[cfg(test)]` modules left out). An edge A -> B is every `use` and every path in A's code that
//! starts with `crate`, `self`, `super` or a child module of A and resolves to an item B defines.
//! A path through a re-export (`pub use`) is followed to the module that defines the item, and the
//! re-export itself is not an edge: a facade `mod.rs` that re-exports its children does not
//! depend on them. Then any strongly connected component of more than one module is a cycle.
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// Every library and binary root of the workspace (not tests, benches or the firmware).
const CRATE_ROOTS: &[&str] = &[
    "scorer-core/src/lib.rs",
    "scorer-core/ffi/src/lib.rs",
    "can-bridge/src/lib.rs",
    "can-bridge/src/main.rs",
    "can-bridge/codec/src/lib.rs",
    "host-tools/src/lib.rs",
    "host-tools/src/main.rs",
    "host-tools/data/src/lib.rs",
    "host-tools/eval/src/lib.rs",
    "host-tools/train/src/lib.rs",
];

type ModPath = Vec<String>;

struct Module {
    file: PathBuf,
    /// Items defined here, by name.
    defines: BTreeSet<String>,
    /// `pub use` re-exports: exported name -> the path it stands for.
    reexports: BTreeMap<String, Vec<String>>,
    /// Every path this module's code names (use trees expanded, re-exports excluded).
    names: Vec<Vec<String>>,
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.parse_args::<syn::Meta>()
                .is_ok_and(|m| m.path().is_ident("test"))
    })
}

/// Expands a use tree into full paths, each with the name it is bound to.
fn expand(tree: &syn::UseTree, prefix: &mut Vec<String>, out: &mut Vec<(Vec<String>, String)>) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            expand(&p.tree, prefix, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) if n.ident == "self" => {
            let name = prefix.last().cloned().unwrap_or_default();
            out.push((prefix.clone(), name));
        }
        syn::UseTree::Name(n) => {
            let mut p = prefix.clone();
            p.push(n.ident.to_string());
            out.push((p, n.ident.to_string()));
        }
        syn::UseTree::Rename(r) => {
            let mut p = prefix.clone();
            p.push(r.ident.to_string());
            out.push((p, r.rename.to_string()));
        }
        syn::UseTree::Glob(_) => out.push((prefix.clone(), "*".into())),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                expand(t, prefix, out);
            }
        }
    }
}

/// Collects what one file defines and names, skipping `#[cfg(test)]` items.
#[derive(Default)]
struct Collector {
    defines: BTreeSet<String>,
    reexports: BTreeMap<String, Vec<String>>,
    names: Vec<Vec<String>>,
    /// `mod name;` declarations.
    children: Vec<String>,
}

impl<'ast> Visit<'ast> for Collector {
    fn visit_item(&mut self, item: &'ast syn::Item) {
        let attrs = match item {
            syn::Item::Mod(m) => &m.attrs,
            syn::Item::Fn(f) => &f.attrs,
            syn::Item::Use(u) => &u.attrs,
            syn::Item::Impl(i) => &i.attrs,
            syn::Item::Const(c) => &c.attrs,
            _ => &Vec::new(),
        };
        if is_cfg_test(attrs) {
            return;
        }
        let ident = match item {
            syn::Item::Struct(i) => Some(&i.ident),
            syn::Item::Enum(i) => Some(&i.ident),
            syn::Item::Fn(i) => Some(&i.sig.ident),
            syn::Item::Const(i) => Some(&i.ident),
            syn::Item::Static(i) => Some(&i.ident),
            syn::Item::Type(i) => Some(&i.ident),
            syn::Item::Trait(i) => Some(&i.ident),
            syn::Item::Union(i) => Some(&i.ident),
            syn::Item::Macro(i) => i.ident.as_ref(),
            _ => None,
        };
        if let Some(ident) = ident {
            self.defines.insert(ident.to_string());
        }
        match item {
            syn::Item::Use(u) => {
                let mut paths = Vec::new();
                expand(&u.tree, &mut Vec::new(), &mut paths);
                let reexport = !matches!(u.vis, syn::Visibility::Inherited);
                for (path, name) in paths {
                    if reexport {
                        self.reexports.insert(name, path);
                    } else {
                        self.names.push(path);
                    }
                }
            }
            syn::Item::Mod(m) if m.content.is_none() => self.children.push(m.ident.to_string()),
            _ => syn::visit::visit_item(self, item),
        }
    }

    /// A macro call (`write!`, `format!`) names a macro, not a module of this crate.
    fn visit_macro(&mut self, _: &'ast syn::Macro) {}

    /// `pub(super)` and `pub(in path)` name where an item is visible, not what it uses.
    fn visit_visibility(&mut self, _: &'ast syn::Visibility) {}

    fn visit_path(&mut self, path: &'ast syn::Path) {
        self.names
            .push(path.segments.iter().map(|s| s.ident.to_string()).collect());
        syn::visit::visit_path(self, path);
    }
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The crate's modules, from its root file through `mod name;` declarations.
fn load_crate(root: &Path) -> BTreeMap<ModPath, Module> {
    let mut modules = BTreeMap::new();
    let mut todo = vec![(Vec::new(), root.to_path_buf())];
    while let Some((path, file)) = todo.pop() {
        let text =
            std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let ast = syn::parse_file(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let mut c = Collector::default();
        c.visit_file(&ast);
        let stem = file
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default();
        let dir = file.parent().unwrap_or(Path::new("."));
        let sub = if matches!(stem, "mod" | "lib" | "main") {
            dir.to_path_buf()
        } else {
            dir.join(stem)
        };
        for child in &c.children {
            let found = [
                sub.join(format!("{child}.rs")),
                sub.join(child).join("mod.rs"),
            ]
            .into_iter()
            .find(|p| p.exists())
            .unwrap_or_else(|| panic!("{}: `mod {child};` has no file", file.display()));
            let mut p = path.clone();
            p.push(child.clone());
            todo.push((p, found));
        }
        modules.insert(
            path,
            Module {
                file,
                defines: c.defines,
                reexports: c.reexports,
                names: c.names,
            },
        );
    }
    modules
}

/// The absolute module path a path written in `module` starts from, or `None` when it names
/// something outside the crate (another crate, a local item, a generic).
fn absolute(
    modules: &BTreeMap<ModPath, Module>,
    module: &ModPath,
    path: &[String],
) -> Option<Vec<String>> {
    let (first, rest) = path.split_first()?;
    let mut base = match first.as_str() {
        "crate" => Vec::new(),
        "self" => module.clone(),
        "super" => module[..module.len().checked_sub(1)?].to_vec(),
        child => {
            let mut p = module.clone();
            p.push(child.to_owned());
            if !modules.contains_key(&p) {
                return None;
            }
            return Some(p.into_iter().chain(rest.iter().cloned()).collect());
        }
    };
    let mut rest = rest;
    while let Some((s, r)) = rest.split_first().filter(|(s, _)| *s == "super") {
        let _ = s;
        base.pop();
        rest = r;
    }
    Some(base.into_iter().chain(rest.iter().cloned()).collect())
}

/// The module that defines what `path` (absolute) names, through re-exports.
fn definer(modules: &BTreeMap<ModPath, Module>, path: &[String], depth: usize) -> Option<ModPath> {
    let k = (0..=path.len())
        .rev()
        .find(|&k| modules.contains_key(&path[..k]))?;
    let module = path[..k].to_vec();
    let Some(name) = path.get(k) else {
        return Some(module);
    };
    let m = &modules[&module];
    if m.defines.contains(name) || depth > 16 {
        return Some(module);
    }
    if let Some(target) = m.reexports.get(name) {
        if let Some(abs) = absolute(modules, &module, target) {
            return definer(modules, &abs, depth + 1).or(Some(module));
        }
    }
    Some(module)
}

/// Strongly connected components with more than one module (Tarjan).
fn cycles(graph: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    struct Tarjan<'g> {
        graph: &'g BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<&'g ModPath, (usize, usize)>,
        stack: Vec<&'g ModPath>,
        next: usize,
        found: Vec<Vec<ModPath>>,
    }
    impl<'g> Tarjan<'g> {
        fn visit(&mut self, v: &'g ModPath) {
            self.index.insert(v, (self.next, self.next));
            self.next += 1;
            self.stack.push(v);
            for w in &self.graph[v] {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let low = self.index[w].1.min(self.index[v].1);
                    self.index.get_mut(v).expect("visited").1 = low;
                } else if self.stack.contains(&w) {
                    let low = self.index[w].0.min(self.index[v].1);
                    self.index.get_mut(v).expect("visited").1 = low;
                }
            }
            if self.index[v].0 == self.index[v].1 {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    component.push(w.clone());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    self.found.push(component);
                }
            }
        }
    }
    let mut t = Tarjan {
        graph,
        index: BTreeMap::new(),
        stack: Vec::new(),
        next: 0,
        found: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    t.found
}

fn module_graph(modules: &BTreeMap<ModPath, Module>) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
    modules
        .iter()
        .map(|(path, m)| {
            let uses = m
                .names
                .iter()
                .filter_map(|n| {
                    let d = definer(modules, &absolute(modules, path, n)?, 0)?;
                    if std::env::var_os("CYCLES_DEBUG").is_some() && &d != path {
                        eprintln!("{} -> {}: {}", path.join("::"), d.join("::"), n.join("::"));
                    }
                    Some(d)
                })
                .filter(|d| d != path)
                .collect();
            (path.clone(), uses)
        })
        .collect()
}

#[test]
fn no_crate_has_a_module_cycle() {
    let mut report = Vec::new();
    for root in CRATE_ROOTS {
        let modules = load_crate(&workspace().join(root));
        assert!(
            modules.len() > 1 || root.ends_with("main.rs"),
            "{root}: no modules found"
        );
        let graph = module_graph(&modules);
        for component in cycles(&graph) {
            let names: Vec<String> = component
                .iter()
                .map(|p| {
                    modules[p]
                        .file
                        .strip_prefix(workspace())
                        .unwrap_or(&modules[p].file)
                        .display()
                        .to_string()
                })
                .collect();
            let edges: Vec<String> = component
                .iter()
                .flat_map(|a| {
                    graph[a]
                        .iter()
                        .filter(|b| component.contains(b))
                        .map(move |b| format!("{} -> {}", a.join("::"), b.join("::")))
                })
                .collect();
            report.push(format!(
                "{root}: {}\n    {}",
                names.join(", "),
                edges.join("\n    ")
            ));
        }
    }
    assert!(report.is_empty(), "module cycles:\n{}", report.join("\n"));
}

#[test]
fn the_check_finds_a_cycle_through_a_reexport() {
    let dir = std::env::temp_dir().join(format!("riskscore-cycles-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::write(dir.join("lib.rs"), "mod a;\nmod b;\npub fn top() {}\n").unwrap();
    // `a` re-exports its child and uses `b`; `b` names `a::Thing`, defined in `a::inner`.
    std::fs::write(
        dir.join("a/mod.rs"),
        "mod inner;\npub use inner::Thing;\nfn f() { crate::b::g(); }\n",
    )
    .unwrap();
    std::fs::write(dir.join("a/inner.rs"), "pub struct Thing;\n").unwrap();
    std::fs::write(
        dir.join("b.rs"),
        "pub fn g() {}\nfn h(_: crate::a::Thing) { super::top(); }\n",
    )
    .unwrap();
    let modules = load_crate(&dir.join("lib.rs"));
    let graph = module_graph(&modules);
    assert!(cycles(&graph).is_empty(), "a -> b -> a::inner is no cycle");
    // `inner` calling back into `a` closes one.
    std::fs::write(
        dir.join("a/inner.rs"),
        "pub struct Thing;\nfn k() { super::f(); }\n",
    )
    .unwrap();
    let modules = load_crate(&dir.join("lib.rs"));
    let found = cycles(&module_graph(&modules));
    assert_eq!(found.len(), 1, "{found:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
