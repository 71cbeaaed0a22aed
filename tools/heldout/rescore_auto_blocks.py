"""The 32x32-block relMSE helpers shared by rescore_auto.py and worst_blocks.py (the same
measure as `lumo bench quality`'s worst_block)."""
import numpy as np

BLOCK = 32

def read_pfm(path):
    """A PFM file as a (height, width, channels) float array, top row first."""
    with open(path, "rb") as fh:
        kind = fh.readline().strip()
        w, h = map(int, fh.readline().split())
        scale = float(fh.readline())
        ch = 3 if kind == b"PF" else 1
        data = np.frombuffer(fh.read(), dtype="<f4" if scale < 0 else ">f4", count=w * h * ch)
    return data.reshape(h, w, ch)[::-1].astype(np.float64)

def block_errors(ref, img):
    """relMSE (epsilon 0.01) summed per BLOCK x BLOCK block, partial blocks kept."""
    e = (img[..., :3] - ref[..., :3]) ** 2 / (ref[..., :3] ** 2 + 0.01)
    e = np.where(np.isfinite(e), e, 0.0).sum(axis=2)
    h, w = e.shape
    bh, bw = -(-h // BLOCK), -(-w // BLOCK)
    padded = np.zeros((bh * BLOCK, bw * BLOCK))
    padded[:h, :w] = e
    return padded.reshape(bh, BLOCK, bw, BLOCK).sum(axis=(1, 3))

def worst_block(ref, noisy, img):
    """(ratio, column, row) of the block where img's error is the largest multiple of noisy's."""
    base, err = block_errors(ref, noisy), block_errors(ref, img)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(base > 0, err / base, np.where(err > 0, np.inf, -1.0))
    k = int(np.argmax(ratio))
    return float(ratio.flat[k]), k % ratio.shape[1], k // ratio.shape[1]
