"""A minimal read-only HDF5 reader (pure numpy) for the files DOLFINx's XDMFFile writes, so that
`make.py --check` can read solution.h5 in reference/.venv (which has no h5py).

Supported: superblock version 0/1 (DOLFINx/HDF5 default "earliest" format), groups as symbol tables
(version 1 B-trees + local heaps + SNOD nodes), version 1 object headers with continuation blocks,
dataspace, datatype (fixed-point and IEEE float, either byte order), data layout contiguous and
compact (layout message versions 1-3).  Anything else (chunked or filtered datasets, superblock
2/3, version 2 object headers) raises NotImplementedError naming it.

    f = H5File("solution.h5"); f.keys("/Mesh/mesh"); f["/Mesh/mesh/geometry"] -> numpy array
"""
import struct

import numpy as np

SIG = b"\x89HDF\r\n\x1a\n"
UNDEF = 0xFFFFFFFFFFFFFFFF


class H5File:
    def __init__(self, path):
        self.path = str(path)
        with open(path, "rb") as fh:
            self.b = fh.read()
        b = self.b
        self.base = 0
        pos = b.find(SIG)
        if pos < 0 or pos % 512:
            raise ValueError(f"{path}: no HDF5 signature")
        self.base = pos
        v = b[pos + 8]
        if v not in (0, 1):
            raise NotImplementedError(f"{path}: superblock version {v}")
        self.so, self.sl = b[pos + 13], b[pos + 14]
        if (self.so, self.sl) != (8, 8):
            raise NotImplementedError(f"{path}: offset/length sizes {self.so}/{self.sl}")
        q = pos + 24 + (4 if v == 1 else 0)
        base_addr = self._u(q, 8)
        self.base = base_addr
        root = q + 4 * 8  # base, free-space, end of file, driver info
        self.root = self._entry(root)
        self.superblock_version = v

    # ------------------------------------------------------------ low level
    def _u(self, p, n):
        return int.from_bytes(self.b[p:p + n], "little")

    def _entry(self, p):
        """symbol table entry -> (name offset, object header address, cache type, scratch btree, heap)."""
        name_off, oh = self._u(p, 8), self._u(p + 8, 8)
        cache = self._u(p + 16, 4)
        bt, hp = self._u(p + 24, 8), self._u(p + 32, 8)
        return dict(name=name_off, header=oh, cache=cache, btree=bt, heap=hp)

    def _heap_data(self, addr):
        p = self.base + addr
        if self.b[p:p + 4] != b"HEAP":
            raise ValueError(f"{self.path}: local heap expected at {addr}")
        return self.base + self._u(p + 24, 8)

    def _name(self, heap_data, off):
        p = heap_data + off
        return self.b[p:self.b.index(b"\0", p)].decode()

    def _group_entries(self, btree, heap):
        hd = self._heap_data(heap)
        out = {}

        def walk(addr):
            p = self.base + addr
            if self.b[p:p + 4] == b"TREE":
                ntype, level, used = self.b[p + 4], self.b[p + 5], self._u(p + 6, 2)
                if ntype != 0:
                    raise NotImplementedError("B-tree node type != 0 in a group")
                q = p + 24 + 8  # past left/right siblings and key 0
                for _ in range(used):
                    walk(self._u(q, 8))
                    q += 16
            elif self.b[p:p + 4] == b"SNOD":
                n = self._u(p + 6, 2)
                for i in range(n):
                    e = self._entry(p + 8 + 40 * i)
                    out[self._name(hd, e["name"])] = e
            else:
                raise ValueError(f"{self.path}: B-tree or symbol node expected at {addr}")
        walk(btree)
        return out

    def _messages(self, addr):
        p = self.base + addr
        if self.b[p] != 1:
            raise NotImplementedError(f"{self.path}: object header version {self.b[p]} at {addr}")
        nmsg = self._u(p + 2, 2)
        size = self._u(p + 8, 4)
        blocks = [(p + 16, size)]
        msgs = []
        while blocks and len(msgs) < nmsg:
            q, sz = blocks.pop(0)
            end = q + sz
            while q + 8 <= end and len(msgs) < nmsg:
                mtype, msize, flags = self._u(q, 2), self._u(q + 2, 2), self.b[q + 4]
                data = q + 8
                if mtype == 0x10:  # continuation
                    blocks.append((self.base + self._u(data, 8), self._u(data + 8, 8)))
                msgs.append((mtype, data, msize, flags))
                q = data + msize
        return msgs

    def _object(self, path):
        parts = [s for s in path.split("/") if s]
        e = self.root
        for s in parts:
            bt, hp = self._group_of(e)
            ents = self._group_entries(bt, hp)
            if s not in ents:
                raise KeyError(f"{self.path}: no {path}")
            e = ents[s]
        return e

    def _group_of(self, e):
        if e["cache"] == 1:
            return e["btree"], e["heap"]
        for mtype, d, _, _ in self._messages(e["header"]):
            if mtype == 0x11:
                return self._u(d, 8), self._u(d + 8, 8)
        raise KeyError("not a group")

    # ------------------------------------------------------------ public
    def keys(self, path="/"):
        e = self._object(path)
        return sorted(self._group_entries(*self._group_of(e)))

    def walk(self, path="/"):
        """all dataset paths under path (depth first, sorted)."""
        out = []
        for k in self.keys(path):
            sub = path.rstrip("/") + "/" + k
            try:
                self._group_of(self._object(sub))
                out += self.walk(sub)
            except KeyError:
                out.append(sub)
        return out

    def dataset_info(self, path):
        e = self._object(path)
        shape = dtype = layout = None
        for mtype, d, msize, _ in self._messages(e["header"]):
            if mtype == 0x01:
                ver, rank, flags = self.b[d], self.b[d + 1], self.b[d + 2]
                q = d + (8 if ver == 1 else 4)
                shape = tuple(self._u(q + 8 * i, 8) for i in range(rank))
            elif mtype == 0x03:
                cls = self.b[d] & 0x0F
                bits = self.b[d + 1]
                size = self._u(d + 4, 4)
                order = ">" if bits & 1 else "<"
                if cls == 0:
                    kind = "i" if bits & 0x08 else "u"
                elif cls == 1:
                    kind = "f"
                else:
                    raise NotImplementedError(f"{self.path}:{path}: datatype class {cls}")
                dtype = np.dtype(f"{order}{kind}{size}")
            elif mtype == 0x08:
                ver = self.b[d]
                if ver == 3:
                    cls = self.b[d + 1]
                    if cls == 1:
                        layout = ("contiguous", self._u(d + 2, 8), self._u(d + 10, 8))
                    elif cls == 0:
                        n = self._u(d + 2, 2)
                        layout = ("compact", d + 4 - self.base, n)
                    else:
                        raise NotImplementedError(f"{self.path}:{path}: layout class {cls} (chunked)")
                elif ver in (1, 2):
                    rank, cls = self.b[d + 1], self.b[d + 2]
                    if cls != 1:
                        raise NotImplementedError(f"{self.path}:{path}: layout v{ver} class {cls}")
                    layout = ("contiguous", self._u(d + 8, 8), None)
                else:
                    raise NotImplementedError(f"{self.path}:{path}: layout message version {ver}")
            elif mtype == 0x0B:
                raise NotImplementedError(f"{self.path}:{path}: filtered (compressed) dataset")
        if shape is None or dtype is None or layout is None:
            raise ValueError(f"{self.path}:{path}: not a dataset")
        return dict(shape=shape, dtype=dtype, layout=layout)

    def __getitem__(self, path):
        i = self.dataset_info(path)
        n = int(np.prod(i["shape"])) if i["shape"] else 1
        kind, addr, _ = i["layout"]
        if addr == UNDEF:
            return np.zeros(i["shape"], dtype=i["dtype"].newbyteorder("="))
        p = self.base + addr
        a = np.frombuffer(self.b, dtype=i["dtype"], count=n, offset=p)
        return a.reshape(i["shape"]).astype(i["dtype"].newbyteorder("="))


if __name__ == "__main__":
    import sys
    f = H5File(sys.argv[1])
    for d in f.walk("/"):
        info = f.dataset_info(d)
        print(d, info["shape"], info["dtype"], info["layout"][0])
