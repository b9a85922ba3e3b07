#!/usr/bin/env python3
"""Import cycles between the files of a crate.

Usage: scripts/import-cycles.py core/src src report/src render/src cpu/src gpu/src

An edge A -> B when file A uses an item of file B: a `use crate::…`,
`use super::…` or `use self::…` path, an inline `crate::a::b` path, or a
parent calling into a child module by path (`run::run(..)`). `crate::X`
re-exported from lib.rs resolves to the file that defines X. The module
tree itself is not a dependency: `mod x;` declarations and `pub use`
re-exports are not edges. Test modules (`#[cfg(test)]` and below) are
skipped. Prints each crate's files, edges and strongly connected
components of more than one file (the cycles)."""
import os, re, sys, itertools

def files(src):
    out = {}
    for d, _, fs in os.walk(src):
        for f in fs:
            if f.endswith('.rs'):
                p = os.path.join(d, f)
                rel = os.path.relpath(p, src)[:-3]
                parts = rel.split(os.sep)
                if parts[-1] in ('mod',):
                    parts = parts[:-1]
                if parts == ['lib']:
                    parts = []
                elif parts == ['main']:
                    parts = ['<main>']
                out[tuple(parts)] = p
    return out

def uses(text):
    text = re.sub(r'//[^\n]*', '', text)
    # strip #[cfg(test)] mod tests { ... } roughly: cut at '#[cfg(test)]'
    i = text.find('#[cfg(test)]')
    if i >= 0: text = text[:i]
    for m in re.finditer(r'(?<!pub )\buse\s+([^;]+);', text, re.S):
        if text[max(0, m.start() - 11):m.start()].strip().endswith(('pub', 'pub(crate)')):
            continue  # a re-export shapes the module tree; it is not a dependency
        yield m.group(1).replace('\n', ' ')
    # inline paths crate::a::b
    text = re.sub(r'pub(\(crate\))? use [^;]+;', '', text)
    for m in re.finditer(r'(?<![\w:])crate::([\w:]+)', text):
        yield 'crate::' + m.group(1)

def expand(tree):
    tree = tree.strip()
    m = re.match(r'^(.*?)::\{(.*)\}$', tree, re.S)
    if not m:
        return [tree]
    base, inner = m.group(1), m.group(2)
    parts, depth, cur = [], 0, ''
    for c in inner:
        if c == '{': depth += 1
        if c == '}': depth -= 1
        if c == ',' and depth == 0:
            parts.append(cur); cur = ''
        else:
            cur += c
    parts.append(cur)
    out = []
    for p in parts:
        p = p.strip()
        if not p: continue
        for e in expand(p):
            out.append(base + '::' + e if e != 'self' else base)
    return out

def reexports(lib_text):
    r = {}
    for m in re.finditer(r'pub use\s+([^;]+);', lib_text, re.S):
        for path in expand(m.group(1).replace('\n', ' ')):
            path = path.split(' as ')[0].strip()
            segs = path.split('::')
            if segs[0] in ('crate', 'self'): segs = segs[1:]
            if segs and segs[-1] != '*':
                r[segs[-1]] = tuple(segs[:-1])
    return r

def resolve(mods, segs):
    # longest prefix that is a module file
    for k in range(len(segs), -1, -1):
        if tuple(segs[:k]) in mods:
            return tuple(segs[:k])
    return ()

def crate_graph(src):
    mods = files(src)
    root = () 
    lib = mods.get(())
    rex = reexports(open(lib).read()) if lib else {}
    g = {m: set() for m in mods}
    for m, p in mods.items():
        text = open(p).read()
        for u in uses(text):
            for path in expand(u):
                path = path.split(' as ')[0].strip()
                segs = path.split('::')
                if segs[0] == 'crate':
                    segs = segs[1:]
                elif segs[0] == 'super':
                    base = list(m)
                    while segs and segs[0] == 'super':
                        base = base[:-1]; segs = segs[1:]
                    segs = base + segs
                elif segs[0] == 'self':
                    segs = list(m) + segs[1:]
                else:
                    continue
                if segs and segs[0] in rex and tuple(segs[:1]) not in mods:
                    segs = list(rex[segs[0]]) + segs
                t = resolve(mods, segs)
                if t != m:
                    g[m].add(t)
        # a parent calling into a child module by path (`run::run(..)`)
        for c in re.findall(r'^\s*(?:pub(?:\(crate\))? )?mod (\w+);', text, re.M):
            body = re.sub(r'pub(\(crate\))? use [^;]+;', '', re.sub(r'//[^\n]*', '', text))
            if re.search(r'(?<![\w:])' + c + r'::', body) and (m + (c,)) in mods:
                g[m].add(m + (c,))
    return g, mods

def cycles(g):
    # Tarjan SCC
    index, low, on, st, out, i = {}, {}, set(), [], [], [0]
    def strong(v):
        index[v] = low[v] = i[0]; i[0] += 1; st.append(v); on.add(v)
        for w in g[v]:
            if w not in index:
                strong(w); low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = st.pop(); on.discard(w); comp.append(w)
                if w == v: break
            if len(comp) > 1: out.append(comp)
    sys.setrecursionlimit(10000)
    for v in g:
        if v not in index: strong(v)
    return out

for src in sys.argv[1:]:
    g, mods = crate_graph(src)
    cs = cycles(g)
    name = lambda m: '/'.join(m) or 'lib/main'
    print(f'{src}: {len(mods)} files, {sum(len(v) for v in g.values())} edges, cycles: {len(cs)}')
    for c in cs:
        print('   ', ' <-> '.join(name(m) for m in c))
