# exr_one_tile.py N SCENE: a scene whose environment is an N x N OpenEXR of
# one ZIP tile (a few hundred KB that decode through a chunk of N*N*12 bytes).
import struct, zlib, base64, json, sys
W = H = int(sys.argv[1])
def attr(name, typ, val): return name.encode()+b'\0'+typ.encode()+b'\0'+struct.pack('<i', len(val))+val
ch = b''.join(c+b'\0'+struct.pack('<iB3xii', 2, 0, 1, 1) for c in (b'B', b'G', b'R')) + b'\0'
hdr = (attr('channels','chlist',ch) + attr('compression','compression',b'\x03') +
       attr('dataWindow','box2i',struct.pack('<4i',0,0,W-1,H-1)) + attr('displayWindow','box2i',struct.pack('<4i',0,0,W-1,H-1)) +
       attr('lineOrder','lineOrder',b'\0') + attr('pixelAspectRatio','float',struct.pack('<f',1)) +
       attr('screenWindowCenter','v2f',struct.pack('<2f',0,0)) + attr('screenWindowWidth','float',struct.pack('<f',1)) +
       attr('tiles','tiledesc',struct.pack('<IIB',W,H,0)) + b'\0')
raw = b'\x80' * (W*H*3*4)
data = zlib.compress(raw, 9)
pre = b'\x76\x2f\x31\x01' + struct.pack('<I', 2 | 0x200) + hdr
off = len(pre) + 8
chunk = struct.pack('<5i', 0, 0, 0, 0, len(data)) + data
exr = pre + struct.pack('<Q', off) + chunk

scene = {"render": {"width": 8, "height": 8, "environment": {"base64": base64.b64encode(exr).decode(), "format": "exr"}},
         "objects": [{"type": "sphere"}]}
json.dump(scene, open(sys.argv[2], 'w'))
