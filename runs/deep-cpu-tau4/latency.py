# Onset latency per layer: input spikes switch on at t=0 (density d, both polarities) and stay
# on; for each layer, the first step at which its spike count reaches half of its mean over
# the last 20 steps. Writes/reads npz by hand (no numpy here).
import sys, zipfile, struct, array, random, ast, subprocess, io
model, binary = sys.argv[1], sys.argv[2]
N, C, H, W, T = 1, 2, 64, 64, 70
d = 0.03
random.seed(1)
vals = array.array('f', [0.0]) * (N * C * H * W * T)
for i in range(N * C * H * W):
    for t in range(T):
        if random.random() < d: vals[i * T + t] = 1.0
def npy(arr, shape):
    hdr = "{'descr': '<f4', 'fortran_order': False, 'shape': %s, }" % (tuple(shape),)
    hdr += ' ' * ((64 - (10 + len(hdr) + 1) % 64) % 64) + '\n'
    return b'\x93NUMPY\x01\x00' + struct.pack('<H', len(hdr)) + hdr.encode() + arr.tobytes()
with zipfile.ZipFile('/tmp/lat_in.npz', 'w') as z: z.writestr('input.npy', npy(vals, (N, C, H, W, T)))
subprocess.run([binary, 'forward', '--model', model, '--input', '/tmp/lat_in.npz', '--output', '/tmp/lat_out.npz', '--threads', '1'], check=True, stdout=subprocess.DEVNULL)
z = zipfile.ZipFile('/tmp/lat_out.npz')
names = sorted(z.namelist(), key=lambda n: int(''.join(c for c in n if c.isdigit()) or 0))
for n in names:
    b = z.read(n); hl = struct.unpack('<H', b[8:10])[0]; h = ast.literal_eval(b[10:10 + hl].decode())
    a = array.array('f'); a.frombytes(b[10 + hl:]); shape = h['shape']; Tn = shape[-1]
    per_t = [0.0] * Tn
    for i in range(len(a) // Tn):
        base = i * Tn
        for t in range(Tn):
            if a[base + t] != 0: per_t[t] += 1
    steady = sum(per_t[-20:]) / 20
    onset = next((t for t in range(Tn) if steady > 0 and per_t[t] >= 0.5 * steady), None)
    print(n, 'onset step', onset, 'steady spikes/step %.1f' % steady)
