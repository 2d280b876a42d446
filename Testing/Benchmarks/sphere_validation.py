#!/usr/bin/env python3
"""Net writer and report parser shared by sphere_validation.sh and sphere_validation_adaptive.sh.

  sphere_validation.py net OUT.srn --sigma S --sphere S (--lattice CELL | --srn NET.srn [--set ID.PARAM=V]...)
      Writes a net that meshes the head phantom and adds, per dipole of DIPOLES and per source
      model, AssembleFEMPoisson (conductivities S) -> AnalyticSphereEEG (sphere_conductivities S).
      --lattice: CreatePhantom (voxel_size 2) -> GenerateBackgroundMesh regular_bcc -> CleaveMesh
      (blend_sigma 1, air stripped). --srn: the modules of NET.srn that its CleaveMesh depends on,
      with their ids and values as in the file (writers, quality and anything downstream dropped),
      each --set applied on top; the analytic spheres take the radii of its CreatePhantom.
  sphere_validation.py rows NET.srn REPORT.json LABEL SIZE [--times]
      One line per dipole and source model from the report of a run of that net; --times adds the
      seconds of the meshing modules (all modules but the dipoles') and of the FEM solve stage.
"""
import argparse
import json
import sys
import xml.etree.ElementTree as ET
from xml.sax.saxutils import escape

DIPOLES = [(z, kind, m, model) for z in (20, 40, 60, 70)
           for kind, m in (('radial', '0 0 0.01'), ('tangential', '0.01 0 0'))
           for model in ('partial_integration', 'venant')]
BRAIN_RADIUS = 78.0  # CreatePhantom's and AnalyticSphereEEG's default brain radius (mm)


def dipole_ids(z, kind, model):
    return f'fem_{model}_{kind}_{z}', f'an_{model}_{kind}_{z}'


def srn_modules(path):
    """[(id, name, [(var, value)])], [(from, fromport, to, toport)] of a .srn file."""
    root = ET.parse(path).getroot()
    strip = lambda v: v[1:-1] if v.startswith('{') and v.endswith('}') else v
    mods = [(m.get('id'), m.get('name'), [(v.get('name'), strip(v.get('val'))) for v in m.findall('var')])
            for m in root.iter('module')]
    conns = [(c.get('from'), c.get('fromport'), c.get('to'), c.get('toport')) for c in root.iter('connection')]
    return mods, conns


def attr(x):
    return escape(x, {'"': '&quot;'})


def write_net(args):
    mods, conns = [], []

    def module(i, name, vars):
        v = ''.join(f'      <var name="{k}" val="{{{attr(x)}}}" substitute="no"/>\n' for k, x in vars)
        mods.append(f'    <module id="{i}" package="TetFlow" name="{name}" version="1.0">\n{v}    </module>\n')

    def connect(a, b, port=0, fromport=0):
        conns.append(f'    <connection id="c{len(conns) + 1}" from="{a}" fromport="{fromport}" to="{b}" toport="{port}"/>\n')

    sphere_vars = [('sphere_conductivities', args.sphere)]
    if args.lattice:
        module('ph', 'CreatePhantom', [('kind', 'head'), ('voxel_size', '2')])
        module('bg', 'GenerateBackgroundMesh', [('kind', 'regular_bcc'), ('cell_size', args.lattice)])
        module('cl', 'CleaveMesh', [('blend_sigma', '1'), ('strip_exterior', '0')])
        connect('ph', 'bg'); connect('ph', 'cl'); connect('bg', 'cl', 1)
        mesh = 'cl'
    else:
        smods, sconns = srn_modules(args.srn)
        cleave = [i for i, name, _ in smods if name == 'CleaveMesh']
        if len(cleave) != 1:
            sys.exit(f'{args.srn}: expected one CleaveMesh, found {len(cleave)}')
        mesh = cleave[0]
        keep, todo = set(), [mesh]  # CleaveMesh and everything upstream of it
        while todo:
            i = todo.pop()
            if i not in keep:
                keep.add(i)
                todo += [a for a, _, b, _ in sconns if b == i]
        sets = {}
        for s in args.set:
            key, eq, val = s.partition('=')
            mid, dot, par = key.partition('.')
            if not (eq and dot and par) or mid not in keep:
                sys.exit(f'--set {s}: not ID.PARAM=VALUE of a kept module ({", ".join(sorted(keep))})')
            sets[(mid, par)] = val
        for i, name, vars in smods:
            if i not in keep:
                continue
            own = {k: x for (mid, k), x in sets.items() if mid == i}
            vars = [(k, own.pop(k, x)) for k, x in vars] + list(own.items())
            module(i, name, vars)
            if name == 'CreatePhantom':
                v = dict(vars)
                if v.get('kind', 'head') != 'head':
                    sys.exit(f'{args.srn}: CreatePhantom {i} is not the head phantom')
                sphere_vars.insert(0, ('radii', ' '.join(v.get(k, d) for k, d in (
                    ('brain_radius', '78'), ('csf_radius', '80'), ('skull_radius', '86'), ('radius', '92')))))
        for a, ap, b, bp in sconns:
            if a in keep and b in keep:
                connect(a, b, bp, ap)
    for z, kind, m, model in DIPOLES:
        f, a = dipole_ids(z, kind, model)
        module(f, 'AssembleFEMPoisson', [('conductivities', args.sigma), ('boundary_condition', 'dipole'),
               ('dipole_position', f'0 0 {z}'), ('dipole_moment', m), ('condition_numbers', 'false'),
               ('source_model', model)])
        module(a, 'AnalyticSphereEEG', [('dipole_position', f'0 0 {z}'), ('dipole_moment', m)] + sphere_vars)
        connect(mesh, f); connect(f, a)
    open(args.out, 'w').write('<?xml version="1.0" encoding="UTF-8"?>\n<network version="tetflow-1">\n  <modules>\n'
        + ''.join(mods) + '  </modules>\n  <connections>\n' + ''.join(conns) + '  </connections>\n</network>\n')


def rows(args):
    r = json.load(open(args.report))
    mods = {m['id']: m for m in r['modules']}
    rep = {i: m.get('report', {}) for i, m in mods.items()}
    cl = next(rep[i] for i, m in mods.items() if m['module'] == 'CleaveMesh')
    brain = BRAIN_RADIUS
    for i, name, vars in srn_modules(args.net)[0]:
        if name == 'CreatePhantom':
            brain = float(dict(vars).get('brain_radius', brain))
    fem_ids = {x for z, kind, _, model in DIPOLES for x in dipole_ids(z, kind, model)}
    mesh_s = sum(m['seconds'] for i, m in mods.items() if i not in fem_ids)
    for z, kind, _, model in DIPOLES:
        fi, ai = dipole_ids(z, kind, model)
        f, a = rep[fi], rep[ai]
        line = (f"{args.label:12s} {args.size:>4s} {cl['tets']:9d} {f['dofs']:8d} {model:19s} {kind:10s} {z:3d} "
                f"{z / brain:.2f} {a['rdm']:.4f} {a['mag']:.4f} {a['ln_mag']:+.4f} {f['iterations']:5d} {a['electrodes']:6d}")
        if args.times:
            solve = sum(s['seconds'] for s in mods[fi].get('stages', []) if s['name'] == 'solve')
            line += f" {mesh_s:7.1f} {solve:7.1f}"
        print(line)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest='cmd', required=True)
    n = sub.add_parser('net')
    n.add_argument('out')
    n.add_argument('--sigma', required=True)
    n.add_argument('--sphere', required=True)
    g = n.add_mutually_exclusive_group(required=True)
    g.add_argument('--lattice')
    g.add_argument('--srn')
    n.add_argument('--set', action='append', default=[])
    r = sub.add_parser('rows')
    for a in ('net', 'report', 'label', 'size'):
        r.add_argument(a)
    r.add_argument('--times', action='store_true')
    a = p.parse_args()
    write_net(a) if a.cmd == 'net' else rows(a)


if __name__ == '__main__':
    main()
