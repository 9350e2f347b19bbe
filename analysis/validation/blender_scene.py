"""Build a validation scene in Blender from its Mitsuba XML and render it
with Cycles to a linear float OpenEXR (R, G, B).

  blender -b --factory-startup --python analysis/validation/blender_scene.py -- \
      SCENE.xml OUT.exr SPP RES [--bounces B] [--seed S] [--threads N]
      [--mutate roughness-linear|two-sided-light|env-no-rotation|env-mirror-u|env-turn-180|instance-order|no-shear|blend-reversed]
      [--png PREVIEW.png]

A glTF scene (SCENE.gltf or .glb) is imported with Blender's own glTF
importer instead and needs --environment MAP [--environment-scale S]: it is
lit only by that lat-long map, read in Mitsuba's frame with the glTF world
(+y up) as the map's frame, as `vkmech render --environment MAP` does; max
bounces 10 (vkmech's default max_depth 12). Square images only unless
--res-y H is given (vkmech's height follows the camera's aspect ratio).

--bounces and --mutate exist only for the sensitivity checks
(sensitivity.sh): they build a deliberately wrong Cycles scene
(instance-order: each instance's objects at to_world(shape) @ to_world(instance),
the composition order reversed, as linked duplicates; no-shear: matrix_world
assigned as it is, so Blender drops a shear, see place()).
--min-light-bounces M sets Cycles' Min Light Bounces (no Russian roulette
at bounce indices <= M; default 0, Cycles' own default); the benchmark sets
it so Russian roulette starts at the same vertex as vkmech's rr_depth.
--threads 0 uses every core (Blender's AUTO thread mode; ci/bench-cycles.sh).
--png also writes an 8-bit sRGB preview of the same render (view transform
Standard, no exposure), after the EXR.

Only the subset of Mitsuba XML that make_scenes.py writes is understood
(everything else is an error, so nothing is silently dropped):
  integrator path (max_depth), perspective sensor (fov, fov_axis x, lookat),
  obj shapes (v, vt, vn, triangles; optional to_world), rectangle, cube
  and sphere shapes (to_world of translate / rotate / scale; sphere center
  and radius), shapegroups and instances (below), bsdfs diffuse
  (rgb or bitmap reflectance), twosided, dielectric, conductor,
  roughconductor (material none, ggx) and blendbsdf (constant or bitmap
  weight, nested bsdfs written inline), area emitters (rgb radiance), one
  envmap emitter (filename, scale, to_world of rotations) and directional
  emitters (direction, rgb irradiance).

Mapping (Mitsuba -> Cycles 3.4):
  diffuse            -> Diffuse BSDF, roughness 0 (Lambert)
  dielectric         -> Glass BSDF, Sharp, IOR int_ior/ext_ior, colour white
  conductor none     -> Glossy BSDF, Sharp, colour specular_reflectance
  roughconductor ggx -> Glossy BSDF, GGX, roughness sqrt(alpha)
                        (Cycles svm closure: alpha = roughness^2)
  blendbsdf          -> Mix Shader (Fac = weight: 0 the first nested bsdf,
                        1 the second); a bitmap weight through RGB to BW
                        (luminance), Non-Color where the bitmap is raw
  rectangle / cube   -> the same quad [-1,1]^2 (normal +z) / box [-1,1]^3
                        as a mesh, transformed by to_world
  sphere             -> UV sphere mesh, 128 segments x 64 rings, smooth
                        shading: the same tessellation as vkmech's sphere
                        (host/engine/scene/primitives.hpp, 16128 triangles,
                        interpolated normals); Mitsuba's is analytic
  area emitter       -> Emission (colour = radiance, strength 1) on the front
                        face only: Mix(Backfacing) with black on the back
  envmap             -> World: Texture Coordinate (Generated = the ray's world
                        direction) -> Mapping (Vector, rotation R) ->
                        Environment Texture (Equirectangular, Linear, image
                        colour space Linear) -> Background (strength =
                        scale). R = P W^T, W = to_world's rotation, P the
                        cyclic permutation (x, y, z) <- (z, x, y) that takes
                        Mitsuba's local lat-long frame to Cycles'
                        (docs/validation.md, "Environment lighting")
  directional        -> Sun lamp, angle 0, strength 1, colour = irradiance
                        (W/m^2), shining along `direction` (its local -z)
  shapegroup         -> a collection, not linked to the scene, holding the
                        group's objects at their own to_world (group space)
  instance           -> an empty instancing that collection (instance_type
                        COLLECTION) with matrix_world = the instance's
                        to_world: Blender places each object at
                        to_world(instance) @ to_world(shape), Mitsuba's order
                        (the shape's own transform first), and Cycles keeps
                        one copy of each mesh, instanced by object transforms
                        (normals by the inverse transpose, as Mitsuba)
  max_depth d        -> max bounces d - 2 for every bounce kind (Mitsuba counts
                        path segments incl. the emitter segment; Cycles counts
                        scattering events after the first hit; checked by
                        rendering both at max_depth 2 and 3)
  film               -> box pixel filter of width 1, no clamping, no
                        denoising, no adaptive sampling, filter-glossy 0,
                        caustics on, black world (unless the scene has an
                        envmap), view transform Standard.
"""
import math
import os
import sys
import xml.etree.ElementTree as ET

import bpy
from mathutils import Matrix, Vector


MUTATE = None


def die(msg):
    print("blender_scene.py: " + msg, file=sys.stderr)
    sys.exit(2)


def floats(s):
    return [float(x) for x in s.replace(",", " ").split()]


def props(node):
    d = {}
    for c in node:
        if "name" in c.attrib:
            d[c.attrib["name"]] = c
    return d


def load_obj(path):
    v, vt, vn, tris = [], [], [], []
    for line in open(path):
        t = line.split()
        if not t or t[0].startswith("#"):
            continue
        if t[0] == "v":
            v.append(tuple(map(float, t[1:4])))
        elif t[0] == "vt":
            vt.append(tuple(map(float, t[1:3])))
        elif t[0] == "vn":
            vn.append(tuple(map(float, t[1:4])))
        elif t[0] == "f":
            if len(t) != 4:
                die(path + ": only triangles")
            corners = []
            for c in t[1:]:
                parts = (c.split("/") + ["", ""])[:3]
                corners.append(tuple(int(p) - 1 if p else -1 for p in parts))
            tris.append(corners)
        else:
            die(path + ": unexpected OBJ record " + t[0])
    return v, vt, vn, tris


def make_mesh(name, path, M=None, coll=None):
    """An OBJ's triangles as a mesh object at matrix_world M (default identity),
    linked to coll (default the scene's collection)."""
    v, vt, vn, tris = load_obj(path)
    me = bpy.data.meshes.new(name)
    me.from_pydata(v, [], [[c[0] for c in f] for f in tris])
    me.update()
    # polygon order and loop order follow the face list exactly
    if vt:
        uv = me.uv_layers.new(name="UVMap")
        for poly, f in zip(me.polygons, tris):
            for li, c in zip(poly.loop_indices, f):
                uv.data[li].uv = vt[c[1]]
    if vn:
        me.use_auto_smooth = True  # Blender 3.x: needed for custom split normals
        normals = [None] * len(me.loops)
        for poly, f in zip(me.polygons, tris):
            for li, c in zip(poly.loop_indices, f):
                normals[li] = vn[c[2]]
        me.normals_split_custom_set(normals)
    ob = bpy.data.objects.new(name, me)
    coll = bpy.context.scene.collection if coll is None else coll
    coll.objects.link(ob)
    place(ob, Matrix.Identity(4) if M is None else M, coll)
    return ob


# Object name -> the world matrix meant for it (place); main() checks every
# rendered mesh object, instanced or not, against it after evaluation.
PLACED = {}


def place(ob, M, coll):
    """Give ob (linked to coll) the world matrix M, shear included. Blender
    keeps an object's own transform as location, rotation and scale, which
    hold no shear: assigning a sheared matrix_world (a rotation followed by a
    non-uniform scale, as some of val_instances' instances are) silently
    keeps only its nearest location/rotation/scale. A sheared M is therefore
    split by its singular value decomposition, M3 = U diag(s) V^T with U and V
    rotations (det M3 > 0), into a parent empty at T U diag(s) (a location,
    rotation and scale) and ob at V^T under it: Blender multiplies the full
    matrices down a parent chain (and into collection instances)."""
    PLACED[ob.name] = M.copy()
    ob.parent = None
    lrs = Matrix.LocRotScale(*M.decompose())
    if (MUTATE == "no-shear" or
            max(abs(a - b) for ra, rb in zip(lrs, M) for a, b in zip(ra, rb)) <= 1e-6 * max(1.0, max(M.to_scale()))):
        ob.matrix_world = M
        return
    import numpy
    A = numpy.array(M.to_3x3(), dtype=float)
    if numpy.linalg.det(A) <= 0:
        die("%s: a mirroring or singular to_world is not mapped here" % ob.name)
    U, sv, Vt = numpy.linalg.svd(A)
    if numpy.linalg.det(U) < 0:  # then det(Vt) < 0 as well: flip one pair of singular vectors
        U[:, 2] *= -1
        Vt[2, :] *= -1
    parent = bpy.data.objects.new(ob.name + " (shear)", None)
    parent.matrix_world = (Matrix.Translation(M.translation) @ Matrix(U.tolist()).to_4x4()
                           @ Matrix.Diagonal(Vector(sv.tolist())).to_4x4())
    coll.objects.link(parent)
    ob.parent = parent
    ob.matrix_parent_inverse = Matrix.Identity(4)
    ob.matrix_basis = Matrix(Vt.tolist()).to_4x4()


def to_world(node):
    """Mitsuba <transform>: each child is applied after the ones before it."""
    M = Matrix.Identity(4)
    if node is None:
        return M
    for t in node:
        if t.tag == "translate":
            if "value" in t.attrib:
                T = Matrix.Translation(Vector(floats(t.attrib["value"])))
            else:
                T = Matrix.Translation(Vector([float(t.attrib.get(k, "0")) for k in "xyz"]))
        elif t.tag == "scale":
            if "value" in t.attrib:
                v = floats(t.attrib["value"])
                v = v * 3 if len(v) == 1 else v
            else:
                v = [float(t.attrib.get(k, "1")) for k in "xyz"]
            T = Matrix.Diagonal(Vector(v)).to_4x4()
        elif t.tag == "rotate":
            axis = Vector([float(t.attrib.get(k, "0")) for k in "xyz"])
            T = Matrix.Rotation(math.radians(float(t.attrib["angle"])), 4, axis.normalized())
        else:
            die("unsupported transform <%s>" % t.tag)
        M = T @ M
    return M


def make_primitive(name, kind, p, coll=None):
    """Mitsuba rectangle, cube or sphere as a Blender mesh object (linked to
    coll, default the scene's collection)."""
    me = bpy.data.meshes.new(name)
    if kind == "sphere":
        import bmesh
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=128, v_segments=64, radius=1.0)
        bm.to_mesh(me)
        bm.free()
        for poly in me.polygons:
            poly.use_smooth = True
        c = Vector(floats(p["center"].attrib["value"])) if "center" in p else Vector((0, 0, 0))
        r = float(p["radius"].attrib["value"]) if "radius" in p else 1.0
        M = Matrix.Translation(c) @ Matrix.Scale(r, 4)
        if "to_world" in p:
            die("sphere: use center and radius, not to_world")
    else:
        if kind == "rectangle":
            v = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
            f = [(0, 1, 2, 3)]  # counter-clockwise seen from +z: normal +z
        else:  # cube [-1,1]^3, outward normals
            v = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
            f = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
        me.from_pydata(v, [], f)
        M = to_world(p.get("to_world"))
    me.update()
    ob = bpy.data.objects.new(name, me)
    coll = bpy.context.scene.collection if coll is None else coll
    coll.objects.link(ob)
    place(ob, M, coll)
    return ob


def make_shape(node, mats, base, coll=None):
    """One Mitsuba shape (not a group or an instance) with its material, as an
    object linked to coll (default the scene's collection)."""
    kind = node.attrib["type"]
    p = props(node)
    if kind == "obj":
        path = os.path.join(base, p["filename"].attrib["value"])
        ob = make_mesh(os.path.basename(path), path, to_world(p.get("to_world")), coll)
    elif kind in ("rectangle", "cube", "sphere"):
        ob = make_primitive(node.attrib.get("id", kind), kind, p, coll)
    else:
        die("unsupported shape " + kind)
    em = node.find("emitter")
    ref = node.find("ref")
    b = node.find("bsdf")
    if em is not None:
        if coll is not None:
            die("a shapegroup holds no emitters (Mitsuba)")
        if em.attrib["type"] != "area":
            die("only area emitters")
        if b is None or b.attrib["type"] != "diffuse" or max(rgb(props(b)["reflectance"])[:3]) != 0:
            die("an emitter's shape must have a black diffuse bsdf here")
        mat = mats.emitter(rgb(props(em)["radiance"]))
    elif ref is not None:
        mat = mats.ref(ref.attrib["id"])
    elif b is not None:
        mat = mats.bsdf(b)
    else:
        die("shape without bsdf")
    ob.data.materials.append(mat)
    return ob


def make_group(node, mats, base):
    """Mitsuba shapegroup -> a collection that is not linked to the scene (so
    it renders only through its instances), its objects at their own to_world
    in the group's space."""
    gid = node.attrib["id"]
    coll = bpy.data.collections.new("group_" + gid)
    for c in node:
        if c.tag != "shape" or c.attrib["type"] in ("shapegroup", "instance"):
            die("shapegroup %s: only plain shapes (no groups, instances or <%s>)" % (gid, c.tag))
        make_shape(c, mats, base, coll)
    print("blender_scene.py: shapegroup %s -> collection %s with %d objects (%d faces)" % (
        gid, coll.name, len(coll.objects), sum(len(o.data.polygons) for o in coll.objects)))
    return coll


def make_instance(node, groups, idx):
    """Mitsuba instance -> an empty instancing the group's collection at the
    instance's to_world (so an object of the group lands at
    to_world(instance) @ to_world(shape)). --mutate instance-order instead
    places linked duplicates (sharing the mesh) at to_world(shape) @
    to_world(instance), the wrong composition order."""
    refs = node.findall("ref")
    if len(refs) != 1 or refs[0].attrib["id"] not in groups:
        die("an instance needs one <ref> to a shapegroup defined before it")
    for c in node:
        if c.tag not in ("ref", "transform"):
            die("instance: unsupported <%s>" % c.tag)
    coll = groups[refs[0].attrib["id"]]
    M = to_world(props(node).get("to_world"))
    if M.to_3x3().determinant() <= 0:
        die("instance %d: a mirroring to_world (Mitsuba keeps the group's facing; not mapped here)" % idx)
    sc = bpy.context.scene.collection
    if MUTATE == "instance-order":
        for ob in [o for o in coll.objects if o.type == "MESH"]:
            dup = ob.copy()  # linked duplicate: shares ob.data
            sc.objects.link(dup)
            place(dup, PLACED[ob.name] @ M, sc)
        return
    e = bpy.data.objects.new("instance%d" % idx, None)
    e.instance_type = "COLLECTION"
    e.instance_collection = coll
    sc.objects.link(e)
    place(e, M, sc)


def rgb(node):
    if node.tag != "rgb":
        die("expected <rgb>, got <%s>" % node.tag)
    c = floats(node.attrib["value"])
    return (c[0], c[1], c[2], 1.0)


def substitute_defaults(root):
    """Mitsuba's <default name=... value=...> at the top level: every "$name" in an attribute
    value becomes the value (no -D on this command line, so the defaults are the scene)."""
    values = {d.attrib["name"]: d.attrib["value"] for d in root if d.tag == "default"}
    for el in root.iter():
        for k, v in el.attrib.items():
            if "$" in v:
                for name in sorted(values, key=len, reverse=True):
                    v = v.replace("$" + name, values[name])
                if "$" in v:
                    die("unbound parameter in %s=%r" % (k, v))
                el.attrib[k] = v


class Materials:
    def __init__(self, base):
        self.base = base
        self.byid = {}
        self.declared = {}  # top-level bsdfs by id, built on first use (a scene may declare unused ones)
        self.count = 0

    def ref(self, ident):
        if ident not in self.byid:
            if ident not in self.declared:
                die("unknown bsdf reference " + ident)
            self.byid[ident] = self.bsdf(self.declared[ident])
        return self.byid[ident]

    def new(self, label):
        self.count += 1
        m = bpy.data.materials.new("%s_%d" % (label, self.count))
        m.use_nodes = True
        nt = m.node_tree
        for n in list(nt.nodes):
            nt.nodes.remove(n)
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        return m, nt, out

    def bsdf(self, node):
        m, nt, out = self.new(node.attrib["type"])
        nt.links.new(self.shader(nt, node), out.inputs["Surface"])
        return m

    def image_node(self, nt, tp, colorspace):
        """A bitmap texture's Image Texture node (uv map UVMap, REPEAT)."""
        img = bpy.data.images.load(os.path.join(self.base, tp["filename"].attrib["value"]))
        img.colorspace_settings.name = colorspace
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.image = img
        ft = tp["filter_type"].attrib["value"] if "filter_type" in tp else "bilinear"
        tex.interpolation = "Closest" if ft == "nearest" else "Linear"
        tex.extension = "REPEAT"
        uvn = nt.nodes.new("ShaderNodeUVMap")
        uvn.uv_map = "UVMap"
        nt.links.new(uvn.outputs["UV"], tex.inputs["Vector"])
        return tex

    def shader(self, nt, node):
        """The shader output socket of a Mitsuba bsdf, built in node tree nt."""
        t = node.attrib["type"]
        if t == "twosided":
            inner = [c for c in node if c.tag == "bsdf"]
            if len(inner) != 1:
                die("twosided needs one nested bsdf")
            return self.shader(nt, inner[0])  # Cycles BSDFs are two-sided already
        p = props(node)
        if t == "blendbsdf":
            # Mix Shader: Fac 0 = the first input (Mitsuba's first nested bsdf), 1 = the second;
            # a textured weight is the texture's luminance (RGB to BW: Rec. 709 weights).
            inner = [c for c in node if c.tag == "bsdf"]
            if len(inner) != 2:
                die("blendbsdf needs two nested bsdfs")
            mix = nt.nodes.new("ShaderNodeMixShader")
            w = p.get("weight")
            if w is None:
                mix.inputs["Fac"].default_value = 0.5
            elif w.tag == "texture":
                tp = props(w)
                if w.attrib["type"] != "bitmap":
                    die("only bitmap textures")
                raw = "raw" in tp and tp["raw"].attrib["value"] == "true"
                tex = self.image_node(nt, tp, "Non-Color" if raw else "sRGB")
                bw = nt.nodes.new("ShaderNodeRGBToBW")
                nt.links.new(tex.outputs["Color"], bw.inputs["Color"])
                nt.links.new(bw.outputs["Val"], mix.inputs["Fac"])
            else:
                mix.inputs["Fac"].default_value = float(w.attrib["value"])
            a, b = (1, 2) if MUTATE != "blend-reversed" else (2, 1)  # the weight read as the first's share
            nt.links.new(self.shader(nt, inner[0]), mix.inputs[a])
            nt.links.new(self.shader(nt, inner[1]), mix.inputs[b])
            return mix.outputs["Shader"]
        if t == "diffuse":
            sh = nt.nodes.new("ShaderNodeBsdfDiffuse")
            sh.inputs["Roughness"].default_value = 0.0
            r = p.get("reflectance")
            if r is None:
                sh.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1)
            elif r.tag == "texture":
                if r.attrib["type"] != "bitmap":
                    die("only bitmap textures")
                tex = self.image_node(nt, props(r), "sRGB")  # Mitsuba bitmap raw=false: sRGB-decoded
                nt.links.new(tex.outputs["Color"], sh.inputs["Color"])
            else:
                sh.inputs["Color"].default_value = rgb(r)
        elif t == "dielectric":
            sh = nt.nodes.new("ShaderNodeBsdfGlass")
            sh.distribution = "SHARP"
            ior = float(p["int_ior"].attrib["value"]) / float(p["ext_ior"].attrib["value"])
            sh.inputs["IOR"].default_value = ior
            sh.inputs["Color"].default_value = (1, 1, 1, 1)
        elif t in ("conductor", "roughconductor"):
            if p["material"].attrib["value"] != "none":
                die("only material none (Fresnel-free) conductors")
            sh = nt.nodes.new("ShaderNodeBsdfGlossy")
            if t == "conductor":
                sh.distribution = "SHARP"
                sh.inputs["Roughness"].default_value = 0.0
            else:
                if p["distribution"].attrib["value"] != "ggx":
                    die("only ggx")
                sh.distribution = "GGX"
                alpha = float(p["alpha"].attrib["value"])
                sh.inputs["Roughness"].default_value = alpha if MUTATE == "roughness-linear" else math.sqrt(alpha)
            sh.inputs["Color"].default_value = rgb(p["specular_reflectance"])
        else:
            die("unsupported bsdf " + t)
        return sh.outputs["BSDF"]

    def emitter(self, radiance):
        """One-sided emission (front = side of the geometric normal), black
        non-reflecting back and front (the Mitsuba light's BSDF is black)."""
        m, nt, out = self.new("emitter")
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = radiance
        em.inputs["Strength"].default_value = 1.0
        black = nt.nodes.new("ShaderNodeEmission")
        black.inputs["Color"].default_value = (0, 0, 0, 1)
        black.inputs["Strength"].default_value = 0.0
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        mix = nt.nodes.new("ShaderNodeMixShader")
        if MUTATE == "two-sided-light":
            mix.inputs["Fac"].default_value = 0.0  # emits on both sides
        else:
            nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(em.outputs["Emission"], mix.inputs[1])
        nt.links.new(black.outputs["Emission"], mix.inputs[2])
        nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])
        return m


# Mitsuba's lat-long frame -> Cycles': a Mitsuba local direction l reads the
# map where Cycles' direction_to_equirectangular reads it for d = P l, with
# d = (l.z, l.x, l.y) (docs/validation.md, "Environment lighting").
P_MITSUBA_TO_CYCLES = Matrix(((0, 0, 1), (1, 0, 0), (0, 1, 0)))


def make_world(node, base):
    """Mitsuba envmap -> Cycles world with the same radiance in every world direction."""
    p = props(node)
    for k in p:
        if k not in ("filename", "scale", "to_world"):
            die("envmap: unsupported property " + k)
    W = to_world(p.get("to_world")).to_3x3()
    for t in (p["to_world"] if "to_world" in p else []):
        if t.tag != "rotate":
            die("envmap: to_world may only rotate")
    return world_from_map(os.path.join(base, p["filename"].attrib["value"]),
                          float(p["scale"].attrib["value"]) if "scale" in p else 1.0, W)


def world_from_map(path, scale, W):
    """A lat-long map in Mitsuba's frame, turned by W (map-local -> Blender
    world), times scale, as the Cycles world (see make_world)."""
    R = P_MITSUBA_TO_CYCLES @ W.transposed()
    if MUTATE == "env-no-rotation":
        R = Matrix.Identity(3)  # the map read in Cycles' own frame (forgetting the conversion)
    elif MUTATE == "env-turn-180":
        R = R @ Matrix.Rotation(math.pi, 3, "Z")  # the map turned by 180 deg about world z
    w = bpy.data.worlds.new("envmap")
    w.use_nodes = True
    nt = w.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    tc = nt.nodes.new("ShaderNodeTexCoord")
    mp = nt.nodes.new("ShaderNodeMapping")
    mp.vector_type = "VECTOR"  # out = Rot(euler) (Scale * in): a direction, no translation
    mp.inputs["Rotation"].default_value = R.to_euler("XYZ")  # Cycles: Rz Ry Rx, as mathutils
    nt.links.new(tc.outputs["Generated"], mp.inputs["Vector"])
    vec = mp.outputs["Vector"]
    if MUTATE == "env-mirror-u":
        # a mirrored map: u -> -u, i.e. Cycles' y -> -y after the rotation
        mp2 = nt.nodes.new("ShaderNodeMapping")
        mp2.vector_type = "VECTOR"
        mp2.inputs["Scale"].default_value = (1.0, -1.0, 1.0)
        nt.links.new(vec, mp2.inputs["Vector"])
        vec = mp2.outputs["Vector"]
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    img = bpy.data.images.load(path)
    img.colorspace_settings.name = "Linear"  # Radiance HDR: linear Rec.709, as vkmech reads it
    tex.image = img
    tex.projection = "EQUIRECTANGULAR"
    tex.interpolation = "Linear"  # bilinear between texel centres, as vkmech
    nt.links.new(vec, tex.inputs["Vector"])
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = scale
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    out = nt.nodes.new("ShaderNodeOutputWorld")
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    w.cycles.sampling_method = "AUTOMATIC"  # importance-sampled (MIS), Cycles' default
    print("blender_scene.py: envmap %s, Mapping rotation (deg) %s, strength %g" % (
        os.path.basename(path), tuple(round(math.degrees(a), 4) for a in R.to_euler("XYZ")),
        bg.inputs["Strength"].default_value))
    return w


def make_sun(node, idx):
    """Mitsuba directional (irradiance E along `direction`) -> Sun lamp of angle 0."""
    p = props(node)
    for k in p:
        if k not in ("direction", "irradiance"):
            die("directional: unsupported property " + k)
    dn = p["direction"]
    if "value" in dn.attrib:
        d = Vector(floats(dn.attrib["value"]))
    else:
        d = Vector([float(dn.attrib.get(k, "0")) for k in "xyz"])
    d.normalize()
    ld = bpy.data.lights.new("sun%d" % idx, type="SUN")
    ld.angle = 0.0
    ld.energy = 1.0  # Sun strength is irradiance in W/m^2
    ld.color = rgb(p["irradiance"])[:3]
    ld.cycles.cast_shadow = True
    ob = bpy.data.objects.new("sun%d" % idx, ld)
    # a Sun lamp shines along its local -z
    ob.matrix_world = (Vector((0, 0, -1)).rotation_difference(d)).to_matrix().to_4x4()
    bpy.context.scene.collection.objects.link(ob)
    print("blender_scene.py: sun along %s, colour %s, strength 1, angle 0" % (tuple(round(c, 6) for c in d), tuple(ld.color)))
    return ob


# glTF is +y up and Blender +z up: the importer maps a glTF point (x, y, z) to
# Blender (x, -z, y). vkmech reads --environment in the map's own Mitsuba
# frame with the glTF world as that frame (no to_world), so the map-local ->
# Blender-world rotation W is that same axis change.
GLTF_TO_BLENDER = Matrix(((1, 0, 0), (0, 0, -1), (0, 1, 0)))


def build_gltf(scene_path, opts, sc):
    """A glTF 2.0 file through Blender's own importer (io_import_scene_gltf2),
    lit only by --environment MAP (times --environment-scale, default 1), as
    vkmech renders `--scene FILE.gltf --environment MAP`. Returns the world,
    vkmech's default max_depth (12) and the camera's aspect ratio."""
    if "--environment" not in opts:
        die("a glTF scene needs --environment MAP (it is lit only by the map)")
    # Blender 3.4.1's importer uses np.bool, which numpy 1.24 removed (Debian's
    # blender 3.4.1 runs on the system numpy): restore the alias it means.
    import numpy
    if not hasattr(numpy, "bool"):
        numpy.bool = bool
    r = bpy.ops.import_scene.gltf(filepath=os.path.abspath(scene_path), import_shading="NORMALS",
                                  merge_vertices=False)
    if "FINISHED" not in r:
        die("the glTF importer failed: %s" % (r,))
    # Blender 3.4.1's importer multiplies the emissiveTexture by emissiveFactor
    # in a (3.4-new) Mix node of type RGBA but links the node's float Result
    # (output 0, disabled for RGBA) to the Principled Emission: Cycles then
    # drops the link and the material does not emit at all. Relink each such
    # link from the enabled output of the same name (the colour Result).
    for m in bpy.data.materials:
        if not m.use_nodes:
            continue
        nt = m.node_tree
        for l in list(nt.links):
            if l.from_node.type == "MIX" and not l.from_socket.enabled:
                good = [o for o in l.from_node.outputs if o.enabled and o.name == l.from_socket.name]
                if len(good) != 1:
                    die("material %s: cannot repair the link from %s" % (m.name, l.from_node.name))
                to = l.to_socket
                nt.links.remove(l)
                nt.links.new(good[0], to)
                print("blender_scene.py: material %s: relinked %s's disabled %s output to %s's %s "
                      "(the 3.4.1 importer's emission Mix bug)" % (m.name, good[0].node.name, "float",
                                                                   to.node.name, to.name))
    cams = [ob for ob in sc.objects if ob.type == "CAMERA"]
    if not cams:
        die("the glTF file has no camera")
    if [ob for ob in sc.objects if ob.type == "LIGHT"]:
        die("the glTF file has lights; only the environment may light it here")
    cam = sorted(cams, key=lambda o: o.name)[0]
    sc.camera = cam
    cam.data.clip_start = 1e-3
    cam.data.clip_end = 1e4
    print("blender_scene.py: glTF camera %s, sensor fit %s, angle_x %.4f deg, angle_y %.4f deg" % (
        cam.name, cam.data.sensor_fit, math.degrees(cam.data.angle_x), math.degrees(cam.data.angle_y)))
    for m in bpy.data.materials:
        if not m.use_nodes:
            continue
        for n in m.node_tree.nodes:
            if n.type == "BSDF_PRINCIPLED":
                print("blender_scene.py: material %s: Principled %s, subsurface %s, specular %.3f, "
                      "emission strength %.3f, linked inputs %s" % (
                          m.name, n.distribution, n.subsurface_method, n.inputs["Specular"].default_value,
                          n.inputs["Emission Strength"].default_value,
                          sorted(i.name for i in n.inputs if i.is_linked)))
            elif n.type == "TEX_IMAGE" and n.image is not None:
                print("blender_scene.py: material %s: image %s, colour space %s, interpolation %s, extension %s" % (
                    m.name, n.image.name, n.image.colorspace_settings.name, n.interpolation, n.extension))
            elif n.type == "NORMAL_MAP":
                print("blender_scene.py: material %s: Normal Map %s, uv %s, strength %.3f" % (
                    m.name, n.space, n.uv_map, n.inputs["Strength"].default_value))
    scale = float(opts.get("--environment-scale", "1"))
    world = world_from_map(os.path.abspath(opts["--environment"]), scale, GLTF_TO_BLENDER)
    aspect = cam.data.sensor_width / cam.data.sensor_height if cam.data.sensor_fit == "VERTICAL" else None
    return world, 12, aspect


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    if len(argv) < 4:
        die("usage: -- SCENE.xml OUT.exr SPP RES [--bounces B] [--seed S]")
    scene_path, out_path, spp, res = argv[0], argv[1], int(argv[2]), int(argv[3])
    opts = dict(zip(argv[4::2], argv[5::2]))
    base = os.path.dirname(os.path.abspath(scene_path))
    global MUTATE
    MUTATE = opts.get("--mutate")
    if MUTATE not in (None, "roughness-linear", "two-sided-light", "env-no-rotation", "env-mirror-u", "env-turn-180",
                      "instance-order", "no-shear", "blend-reversed"):
        die("unknown --mutate " + MUTATE)

    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)
    sc = bpy.context.scene

    mats = Materials(base)
    groups, instances = {}, []
    max_depth = None
    world = None
    suns = 0
    res_y = res
    is_gltf = scene_path.lower().endswith((".gltf", ".glb"))
    root = [] if is_gltf else ET.parse(scene_path).getroot()
    if not is_gltf:
        substitute_defaults(root)
    if is_gltf:
        world, max_depth, _ = build_gltf(scene_path, opts, sc)
        res_y = int(opts.get("--res-y", res))
    for node in root:
        if node.tag == "integrator":
            if node.attrib["type"] != "path":
                die("integrator must be path")
            p = props(node)
            max_depth = int(p["max_depth"].attrib["value"])
        elif node.tag == "sensor":
            if node.attrib["type"] != "perspective":
                die("sensor must be perspective")
            p = props(node)
            if p.get("fov_axis") is not None and p["fov_axis"].attrib["value"] != "x":
                die("fov_axis must be x")
            la = p["to_world"].find("lookat")
            if la is None or len(p["to_world"]) != 1:
                die("sensor to_world must be a single lookat")
            o = Vector(floats(la.attrib["origin"]))
            tgt = Vector(floats(la.attrib["target"]))
            up = Vector(floats(la.attrib["up"]))
            fwd = (tgt - o).normalized()
            # Mitsuba: camera +x = cross(up, fwd) is image LEFT; Blender camera
            # +x is image right, +y up, looks along -z.
            right = fwd.cross(up).normalized()
            up2 = right.cross(fwd)
            M = Matrix.Identity(4)
            for i in range(3):
                M[i][0], M[i][1], M[i][2], M[i][3] = right[i], up2[i], -fwd[i], o[i]
            cd = bpy.data.cameras.new("cam")
            cd.sensor_fit = "HORIZONTAL"
            cd.angle_x = math.radians(float(p["fov"].attrib["value"]))
            cd.clip_start = 1e-3
            cd.clip_end = 1e4
            cam = bpy.data.objects.new("cam", cd)
            cam.matrix_world = M
            sc.collection.objects.link(cam)
            sc.camera = cam
        elif node.tag == "default":
            continue  # applied by substitute_defaults
        elif node.tag == "bsdf":
            mats.declared[node.attrib["id"]] = node  # built when a shape refers to it
        elif node.tag == "shape" and node.attrib["type"] == "shapegroup":
            groups[node.attrib["id"]] = make_group(node, mats, base)
        elif node.tag == "shape" and node.attrib["type"] == "instance":
            make_instance(node, groups, len(instances))
            instances.append(node)
        elif node.tag == "shape":
            make_shape(node, mats, base)
        elif node.tag == "emitter":
            t = node.attrib["type"]
            if t == "envmap":
                if world is not None:
                    die("a second envmap")
                world = make_world(node, base)
            elif t == "directional":
                make_sun(node, suns)
                suns += 1
            else:
                die("unsupported top-level emitter " + t)
        else:
            die("unsupported top-level element <%s>" % node.tag)

    # Every rendered mesh object's evaluated world matrix against the one
    # meant for it: to_world(shape), or to_world(instance) @ to_world(shape).
    dg = bpy.context.evaluated_depsgraph_get()
    inst, checked, worst = [], 0, 0.0
    for i in dg.object_instances:  # each item is valid only during its own iteration step
        if i.object.type != "MESH" or i.object.name not in PLACED:
            continue
        want = PLACED[i.object.name]
        if i.is_instance:
            inst.append(i.object.data.name)
            want = PLACED[i.parent.name] @ want  # parent: the instancing empty
        # relative to the matrix's largest entry (float32 world matrices)
        big = max(1.0, max(abs(x) for r in want for x in r))
        worst = max(worst, max(abs(a - b) for ra, rb in zip(i.matrix_world, want) for a, b in zip(ra, rb)) / big)
        checked += 1
    print("blender_scene.py: %d mesh objects' world matrices as meant, max |difference| %.2g (relative to the "
          "largest entry)" % (checked, worst))
    if worst > 1e-5 and MUTATE != "no-shear":
        die("an object's world matrix is not its to_world")
    if instances:
        print("blender_scene.py: %d instances%s; the depsgraph has %d instanced mesh objects sharing %d meshes" % (
            len(instances), " (mutated: instance-order, as linked duplicates)" if MUTATE == "instance-order" else "",
            len(inst), len(set(inst))))
    if world is None:
        # World: black (the scene has no environment).
        world = bpy.data.worlds.new("black")
        world.use_nodes = True
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
        world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    sc.world = world

    r = sc.render
    r.engine = "CYCLES"
    r.resolution_x = res
    r.resolution_y = res_y
    r.resolution_percentage = 100
    r.film_transparent = False
    r.use_persistent_data = False
    threads = int(opts.get("--threads", "2"))
    if threads == 0:
        r.threads_mode = "AUTO"  # every core, as lavapipe uses
    else:
        r.threads_mode = "FIXED"
        r.threads = threads
    c = sc.cycles
    c.device = "CPU"
    c.samples = spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = int(opts.get("--seed", "0"))
    bounces = int(opts["--bounces"]) if "--bounces" in opts else max_depth - 2
    c.max_bounces = bounces
    c.diffuse_bounces = bounces
    c.glossy_bounces = bounces
    c.transmission_bounces = bounces
    c.volume_bounces = 0
    c.transparent_max_bounces = bounces
    c.min_light_bounces = int(opts.get("--min-light-bounces", "0"))
    c.min_transparent_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.light_sampling_threshold = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.film_exposure = 1.0  # Cycles film exposure is a linear multiplier (1 = none)
    vs = sc.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    im = r.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    r.use_compositing = False
    r.use_sequencer = False
    r.filepath = os.path.abspath(out_path)
    print("blender_scene.py: %s -> %s, %d spp, %dx%d, max bounces %d, min light bounces %d, threads %s"
          % (scene_path, out_path, spp, res, res_y, bounces, c.min_light_bounces, r.threads_mode))
    bpy.ops.render.render(write_still=True)
    if "--png" in opts:
        im.file_format = "PNG"
        im.color_mode = "RGB"
        im.color_depth = "8"
        bpy.data.images["Render Result"].save_render(os.path.abspath(opts["--png"]), scene=sc)


main()
