"""A second implementation of the meshmark mark (format 2), written from docs/format.md alone.

It shares no code with the library: its hashes come from Python's hashlib (BLAKE2b), the
argon2-cffi package (Argon2id, from the Argon2 reference implementation) and the cryptography
package (ChaCha20), its BCH code, Feistel network, mask, layout, carrier and
histogram from the page's sections 1 to 5. check_vectors.py compares what it computes with the
page's test vectors and with what the meshmark command line writes and reads.
"""
import hashlib, math, struct, sys
from argon2.low_level import Type, hash_secret_raw
from cryptography.hazmat.primitives.ciphers import Cipher, algorithms


def b2b(data, key=b"", n=32):
    return hashlib.blake2b(data, digest_size=n, key=key).digest()


def key_from_passphrase(p: bytes):
    """Argon2id version 1.3, 3 passes over 64 MiB, one lane, a 32-byte key (section 2.2)."""
    salt = b2b(b"meshmark/passphrase/v2/salt\x00")[:16]
    return hash_secret_raw(p, salt, time_cost=3, memory_cost=64 * 1024, parallelism=1,
                           hash_len=32, type=Type.ID, version=19)


def key_from_passphrase_v1(p: bytes):
    return b2b(b"meshmark/passphrase/v1\x00" + p)


def key_from_file(path):
    return b2b(b"meshmark/key-file/v1\x00" + open(path, "rb").read())


PUBLIC = key_from_passphrase_v1(b"meshmark public whitening key")


def derive_key(key, purpose):
    return b2b(("meshmark/mark-v2/" + purpose).encode(), key=key)


def fingerprint(key):
    return derive_key(key, "fingerprint")[:16].hex()


def row_mac(key, row):
    """The MAC of a registry row (a dict of its columns), section 7.2."""
    fields = ["meshmark registry row 1"]
    for name in ("original_hash", "original_path", "buyer", "id", "id_bits", "bits", "variant",
                 "strength", "strength_spread", "bin_offset", "key_fingerprint", "mark_format",
                 "issued_at", "output_path", "output_hash", "method", "original_geometry",
                 "key_derivation", "state"):
        v = row[name]
        fields.append("%.17g" % v if isinstance(v, float) else str(v))
    message = b"".join(struct.pack("<I", len(f.encode())) + f.encode() for f in fields)
    return b2b(message, key=derive_key(key, "registry row")).hex()


def keyed_hash_bits(key, domain, data, nbits):
    out_len = max((nbits + 7) // 8, 16)
    d = b2b(domain.encode() + b"\x00" + bytes(data), key=key, n=out_len)
    return [(d[i // 8] >> (7 - i % 8)) & 1 for i in range(nbits)]


def chacha20_stream(key, nonce_u64, nbytes):
    # libsodium crypto_stream_chacha20: original ChaCha20, 64-bit nonce, 64-bit counter from 0.
    iv = b"\x00" * 8 + struct.pack("<Q", nonce_u64)
    enc = Cipher(algorithms.ChaCha20(key, iv), mode=None).encryptor()
    return enc.update(b"\x00" * nbytes)


class Words:
    def __init__(self, key, nonce):
        self.s = chacha20_stream(key, nonce, 1 << 16)
        self.p = 0

    def next(self):
        w = struct.unpack_from("<I", self.s, self.p)[0]
        self.p += 4
        return w

    def below(self, bound):
        limit = (1 << 32) - (1 << 32) % bound
        while True:
            w = self.next()
            if w < limit:
                return w % bound


def layout(key, nb):
    ks = Words(derive_key(key, "layout"), nb)
    bin_of = list(range(nb))
    for i in range(nb - 1, 0, -1):
        r = ks.below(i + 1)
        bin_of[i], bin_of[r] = bin_of[r], bin_of[i]
    white = [ks.next() >> 31 for _ in range(nb)]
    return bin_of, white


PRIM = {3: 0xB, 4: 0x13, 5: 0x25, 6: 0x43, 7: 0x89, 8: 0x11D, 9: 0x211, 10: 0x409}


def log2_ball(n, t):
    return math.log2(sum(math.comb(n, i) for i in range(min(t, n) + 1)))


class IdCode:
    def __init__(self, n=64, id_bits=32, fa=1e-6, retries=15):
        self.n, self.id_bits = n, id_bits
        inner = n - 1
        m = 3
        while (1 << m) - 1 < inner:
            m += 1
        N = (1 << m) - 1
        self.m, self.N = m, N

        def roots(t):
            r = set()
            for i in range(1, 2 * t + 1):
                j = i % N
                while j not in r:
                    r.add(j)
                    j = 2 * j % N
            return r

        t_ = -1
        t = 0
        while 2 * t + 1 < N:
            if inner - len(roots(t)) >= id_bits:
                t_ = t
            t += 1
        term = lambda w, e: 2 ** (id_bits - (n - w) + log2_ball(n - w, e))
        budget = fa - retries * term(0, 0)
        e0 = max(e for e in range(t_ + 1) if term(0, e) <= budget)
        rules = [(0, e0)]
        left = budget - term(0, e0)
        reach = e0
        for e in range(e0 - 1, -1, -1):
            s = t_ - e
            while s + e > reach:
                if term(s, e) <= left:
                    rules.append((s, e)); left -= term(s, e); reach = s + e
                    break
                s -= 1
        used = sum(term(w, e) for w, e in rules)
        retry = 0
        for e in range(1, t_ + 1):
            if used + retries * term(0, e) <= fa:
                retry = e
        self.rules, self.retry, self.t = rules, retry, t_
        self.bound = used + retries * term(0, retry)
        R = sorted(roots(t_))
        self.r = len(R)
        self.k = inner - self.r
        exp = [0] * (2 * N)
        log = [0] * (N + 1)
        x = 1
        for i in range(N):
            exp[i] = exp[i + N] = x
            log[x] = i
            x <<= 1
            if x & (1 << m):
                x ^= PRIM[m]
        g = [1]
        for j in R:  # multiply by (x + alpha^j)
            nxt = [0] * (len(g) + 1)
            for i, c in enumerate(g):
                nxt[i + 1] ^= c
                if c:
                    nxt[i] ^= exp[(log[c] + j) % N]
            g = nxt
        assert all(c in (0, 1) for c in g)
        self.g = g

    def encode_message(self, msg):
        n, k, r = self.n, self.k, self.r
        inner = n - 1
        c = [0] * inner
        for i in range(k):
            c[inner - 1 - i] = msg[i]
        a = c[:]
        for d in range(inner - 1, r - 1, -1):
            if a[d]:
                for i in range(r + 1):
                    a[d - r + i] ^= self.g[i]
        c[:r] = a[:r]
        out = [c[inner - 1 - j] for j in range(inner)]
        out.append(sum(out) % 2)
        return out

    def feistel(self, x, ck, inverse=False):
        k, a = self.k, self.k // 2
        x = x[:]
        for step in range(8):
            rnd = 7 - step if inverse else step
            right = rnd % 2 == 0
            frm, flen = (0, a) if right else (a, k - a)
            to, tlen = (a, k - a) if right else (0, a)
            if tlen == 0:
                continue
            data = [rnd, k & 255, k >> 8, self.id_bits, self.n & 255, self.n >> 8]
            half = [0] * ((flen + 7) // 8)
            for i in range(flen):
                half[i // 8] |= x[frm + i] << (7 - i % 8)
            f = keyed_hash_bits(ck, "id-feistel", data + half, tlen)
            for i in range(tlen):
                x[to + i] ^= f[i]
        return x

    def mask(self, key):
        out = []
        for done in range(0, self.n, 512):
            data = [self.n & 255, self.n >> 8, done // 512]
            out += keyed_hash_bits(derive_key(key, "id-code"), "id-mask", data, min(512, self.n - done))
        return out

    def encode(self, ident, key):
        k, ib = self.k, self.id_bits
        x = [0] * k
        for i in range(ib):
            x[k - ib + i] = (ident >> (ib - 1 - i)) & 1
        w = self.encode_message(self.feistel(x, derive_key(key, "id-code")))
        return [b ^ m for b, m in zip(w, self.mask(key))]


def strengths(key, nb, alpha, spread):
    k = derive_key(key, "strengths")
    out = []
    for first in range(0, nb, 32):
        blk = first // 32
        bits = keyed_hash_bits(k, "strengths", [blk & 255, blk >> 8], 512)
        for q in range(min(32, nb - first)):
            v = int("".join(map(str, bits[16 * q:16 * q + 16])), 2)
            out.append(max(alpha, min(alpha * (1 + spread * v / 65536.0), 0.49)))
    return out


def hexword(bits):
    return "%0*x" % ((len(bits) + 3) // 4, int("".join(map(str, bits)), 2))


# ---- the carrier and the reader -------------------------------------------------------------
def read_obj(path):
    V, F = [], []
    for line in open(path):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            V.append(tuple(float(c) for c in p[1:4]))
        elif p[0] == "f":
            idx = [int(c.split("/")[0]) for c in p[1:]]
            idx = [i - 1 if i > 0 else len(V) + i for i in idx]
            for i in range(1, len(idx) - 1):
                F.append((idx[0], idx[i], idx[i + 1]))
    return V, F


# ---- the registry's geometry hash (section 7.1) ---------------------------------------------
def geometry_hash(V, F):
    import struct
    f32 = lambda x: struct.unpack("<f", struct.pack("<f", x))[0] + 0.0  # round, -0 -> +0
    used = sorted({i for t in F for i in t})
    pos = {i: tuple(f32(c) for c in V[i]) for i in used}
    unique = sorted(set(pos.values()))
    rank = {p: k for k, p in enumerate(unique)}
    faces = set()
    for t in F:
        r = [rank[pos[i]] for i in t]
        if len(set(r)) < 3:
            continue
        k = r.index(min(r))
        faces.add(tuple(r[k:] + r[:k]))
    h = hashlib.blake2b(digest_size=32)
    h.update(b"meshmark geometry 1")
    h.update(struct.pack("<Q", len(unique)))
    for p in unique:
        h.update(struct.pack("<3f", *p))
    h.update(struct.pack("<Q", len(faces)))
    for t in sorted(faces):
        h.update(struct.pack("<3I", *t))
    return h.hexdigest()


def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
def dot(a, b): return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def carrier(V, F):
    used = [0] * len(V)
    for a, b, c in F:
        pa, pb, pc = V[a], V[b], V[c]
        if pa == pb or pb == pc or pc == pa:
            continue
        u, v = sub(pb, pa), sub(pc, pa)
        w = cross(u, v)
        if dot(w, w) <= 1e-18 * dot(u, u) * dot(v, v):
            continue
        used[a] = used[b] = used[c] = 1
    for f in F:
        for i in f:
            if used[i] == 0:
                used[i] = 2
    first, leader = {}, [-1] * len(V)
    for i, p in enumerate(V):
        if used[i]:
            key = tuple(c + 0.0 for c in p)
            leader[i] = first.setdefault(key, i)
    carried = set(leader[i] for i in range(len(V)) if used[i] == 1)
    return [0 if leader[i] < 0 or leader[i] not in carried else (1 if leader[i] == i else 2)
            for i in range(len(V))]


def extract(V, F, nb):
    mask = carrier(V, F)
    pts = [V[i] for i in range(len(V)) if mask[i] == 1]
    C = tuple(sum(p[k] for p in pts) / len(pts) for k in range(3))  # discrete center (D)
    rho = [math.dist(p, C) for p in pts]
    lo, hi = min(rho), max(rho)
    s = (hi - lo) / (nb + 2)
    sums, cnt = [0.0] * nb, [0] * nb
    for r in rho:
        x = (r - lo) / s
        b = min(math.floor(x), nb + 1)
        if 1 <= b <= nb:
            sums[b - 1] += x - b
            cnt[b - 1] += 1
    means = [sums[j] / cnt[j] if cnt[j] else float("nan") for j in range(nb)]
    bits = [2 if not cnt[j] else int(means[j] > 0.5) for j in range(nb)]
    return bits, means, cnt, C, lo, hi
