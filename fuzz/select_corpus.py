#!/usr/bin/env python3
"""Picks at most --max-files inputs (and at most --max-bytes in all) of a fuzz target's corpus
that keep as much of its coverage as they can, and copies them to OUT named by their SHA-1, as
libFuzzer names corpus files. Used when a plain `-merge=1` keeps more than the budget of the
kept corpus (fuzz/README.md):

    python3 select_corpus.py FUZZ_BINARY OUT CORPUS_DIR... [--max-files 150] [--max-bytes 1500000]

Each input's full edge and feature sets are measured on its own (a libFuzzer merge control file
records only what each input adds to those before it); then greedily the input adding the most
new edges is taken (ties: the most new features, then the smaller), and the budget filled with
the inputs adding the most new features.
"""
import argparse, hashlib, os, shutil, subprocess, tempfile


def coverage(binary, path, max_len):
    with tempfile.TemporaryDirectory() as tmp:
        src, dst, cf = os.path.join(tmp, 'in'), os.path.join(tmp, 'out'), os.path.join(tmp, 'cf')
        os.mkdir(src)
        os.mkdir(dst)
        shutil.copyfile(path, os.path.join(src, 'x'))
        subprocess.run([binary, '-merge=1', f'-merge_control_file={cf}', f'-max_len={max_len}',
                        '-rss_limit_mb=2048', '-timeout=10', dst, src],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        cov, ft = set(), set()
        if os.path.exists(cf):
            for line in open(cf):
                parts = line.split()
                if parts and parts[0] == 'COV':
                    cov |= set(parts[2:])
                elif parts and parts[0] == 'FT':
                    ft |= set(parts[2:])
        return cov, ft


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('binary')
    ap.add_argument('out')
    ap.add_argument('corpus', nargs='+')
    ap.add_argument('--max-files', type=int, default=150)
    ap.add_argument('--max-bytes', type=int, default=1_500_000)
    ap.add_argument('--max-len', type=int, default=65536)
    a = ap.parse_args()
    files = sorted(os.path.join(d, f) for d in a.corpus for f in os.listdir(d))
    cov, ft, size = {}, {}, {}
    for f in files:
        cov[f], ft[f] = coverage(a.binary, f, a.max_len)
        size[f] = os.path.getsize(f)
    have_cov, have_ft, chosen, total = set(), set(), [], 0
    candidates = set(files)
    while len(chosen) < a.max_files and candidates:
        best = max(candidates, key=lambda f: (len(cov[f] - have_cov), len(ft[f] - have_ft), -size[f]))
        candidates.discard(best)
        if not (cov[best] - have_cov or ft[best] - have_ft):
            break
        if total + size[best] > a.max_bytes:
            continue
        chosen.append(best)
        total += size[best]
        have_cov |= cov[best]
        have_ft |= ft[best]
    all_cov = set().union(*cov.values())
    all_ft = set().union(*ft.values())
    os.makedirs(a.out, exist_ok=True)
    for f in chosen:
        data = open(f, 'rb').read()
        shutil.copyfile(f, os.path.join(a.out, hashlib.sha1(data).hexdigest()))
    print(f'{len(chosen)} of {len(files)} files, {total} bytes: {len(have_cov)}/{len(all_cov)} '
          f'edges, {len(have_ft)}/{len(all_ft)} features')


main()
