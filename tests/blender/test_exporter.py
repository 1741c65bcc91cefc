"""The exporter, the render job and the operators' error paths inside the bpy module (5.0.1 in
``.venv``, 5.3 in ``.venv-bpy53``): modifiers, shape keys and geometry-node instances come from
the evaluated depsgraph; hidden and non-casting objects are handled; Blender's camera and light
fields arrive; meshes that did not change are neither read again nor sent again; cancelling
leaves complete frames only; bad input and a missing daemon are reported with the object or the
fix named."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import sys
import tempfile
from pathlib import Path

# Blender writes into $HOME: keep it out of the real one. Set before bpy is imported.
os.environ["HOME"] = tempfile.mkdtemp(prefix="antumbra-bpy-home-")

import subprocess

import bpy
import numpy as np
import pytest
from conftest import ADDON, blender_env


def _load_addon():
    """The add-on package from this checkout, imported as ``antumbra_addon`` (its own name,
    ``antumbra``, is the client's in this process)."""
    init = ADDON / "antumbra" / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "antumbra_addon", init, submodule_search_locations=[str(init.parent)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["antumbra_addon"] = module
    spec.loader.exec_module(module)
    return module


addon = _load_addon()
from antumbra_addon import client_loader, daemon  # noqa: E402
from antumbra_addon.export import exporter as export  # noqa: E402
from antumbra_addon.jobs import frame_job  # noqa: E402
from antumbra_addon.properties import method_settings, options, preferences  # noqa: E402

client = addon.client_loader.load()


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 48, 32
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0.0, -12.0, 6.0)
    camera.rotation_euler = (1.1, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


def add_mesh(scene, name, vertices, faces, location=(0, 0, 0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


CUBE_V = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0, 1)]
CUBE_F = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
GROUND = ([(-8, -8, 0), (8, -8, 0), (8, 8, 0), (-8, 8, 0)], [(0, 1, 2, 3)])


def add_light(scene, name, kind, location=(0, 0, 8), **fields):
    data = bpy.data.lights.new(name, kind)
    for key, value in fields.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    obj.location = location
    scene.collection.objects.link(obj)
    return obj


def export_now(scene, exporter=None):
    exporter = exporter or export.Exporter(client)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return exporter.frame(depsgraph, scene, scene.frame_current, 100), exporter


def by_name(frame_export):
    return {o["name"]: o for o in frame_export.objects}


@pytest.mark.bpy
def test_modifiers_and_shape_keys_are_evaluated():
    scene = empty_scene()
    arrayed = add_mesh(scene, "Arrayed", CUBE_V, CUBE_F)
    modifier = arrayed.modifiers.new("Array", "ARRAY")
    modifier.count = 3
    keyed = add_mesh(scene, "Keyed", *GROUND, location=(0, 0, -1))
    keyed.shape_key_add(name="Basis")
    up = keyed.shape_key_add(name="Up")
    for point in up.data:
        point.co.z += 2.0
    up.value = 1.0
    e, _ = export_now(scene)
    objects = by_name(e)
    arrayed_mesh = e.meshes[objects["Arrayed"]["mesh_hash"]]
    assert len(arrayed_mesh.triangles) == 3 * 12
    assert arrayed_mesh.positions[:, 0].max() == pytest.approx(2.5)
    keyed_mesh = e.meshes[objects["Keyed"]["mesh_hash"]]
    assert np.allclose(keyed_mesh.positions[:, 2], 2.0)
    assert e.triangles == 36 + 2


@pytest.mark.bpy
def test_geometry_node_instances_are_one_array():
    scene = empty_scene()
    cube = add_mesh(scene, "Cube", CUBE_V, CUBE_F)
    points = add_mesh(scene, "Points", [(x, 3.0, 0.0) for x in (-3, -1, 1, 3)], [])
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in = tree.nodes.new("NodeGroupInput")
    group_out = tree.nodes.new("NodeGroupOutput")
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    info = tree.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = cube
    tree.links.new(group_in.outputs[0], on_points.inputs["Points"])
    tree.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    tree.links.new(on_points.outputs["Instances"], group_out.inputs[0])
    points.modifiers.new("Scatter", "NODES").node_group = tree
    e, _ = export_now(scene)
    # The cube itself is an object; its four instances one array.
    assert [o["name"] for o in e.objects] == ["Cube"], [o["name"] for o in e.objects]
    (array,) = e.instances
    assert array["name"] == "Points"  # the instancer's: Object Info hands over geometry
    assert array["mesh_hash"] == by_name(e)["Cube"]["mesh_hash"]
    assert array["matrices"].shape == (4, 4, 4)
    assert sorted(np.round(array["matrices"][:, 0, 3], 4)) == [-3.0, -1.0, 1.0, 3.0]
    assert sorted(array["ids"].tolist()) == [0, 1, 2, 3]
    assert e.placements() == 5


@pytest.mark.bpy
def test_hidden_and_non_casting_objects_and_lights():
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    hidden = add_mesh(scene, "Hidden", CUBE_V, CUBE_F)
    hidden.hide_render = True
    ghost = add_mesh(scene, "Ghost", CUBE_V, CUBE_F, location=(2, 0, 0))
    ghost.visible_shadow = False
    invisible = add_mesh(scene, "Nothing", CUBE_V, CUBE_F)
    invisible.visible_camera = False
    invisible.visible_shadow = False
    add_light(scene, "Lamp", "POINT", shadow_soft_size=0.3)
    add_light(scene, "Sun", "SUN", angle=0.05)
    add_light(scene, "Spot", "SPOT", spot_size=0.7, spot_blend=0.2, shadow_soft_size=0.1)
    add_light(scene, "Panel", "AREA", shape="RECTANGLE", size=2.0, size_y=0.5)
    add_light(scene, "Off", "POINT").hide_render = True
    e, _ = export_now(scene)
    objects = by_name(e)
    assert set(objects) == {"Ground", "Ghost"}
    assert objects["Ghost"]["visible_shadow"] is False
    assert objects["Ghost"]["visible_camera"] is True
    lights = {light["name"]: light for light in e.lights}
    assert set(lights) == {"Lamp", "Sun", "Spot", "Panel"}
    assert lights["Lamp"]["shadow_soft_size"] == pytest.approx(0.3)
    assert lights["Sun"]["angle"] == pytest.approx(0.05)
    assert lights["Spot"]["spot_size"] == pytest.approx(0.7)
    assert lights["Spot"]["spot_blend"] == pytest.approx(0.2)
    assert (lights["Panel"]["shape"], lights["Panel"]["size_y"]) == ("RECTANGLE", 0.5)


@pytest.mark.bpy
def test_camera_fields_and_unsupported_cameras():
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    cam = scene.camera.data
    cam.lens, cam.sensor_fit, cam.sensor_height = 35.0, "VERTICAL", 20.0
    cam.shift_x, cam.clip_start, cam.clip_end = 0.1, 0.2, 50.0
    scene.render.resolution_percentage = 50
    scene.render.pixel_aspect_x = 2.0
    depsgraph = bpy.context.evaluated_depsgraph_get()
    e = export.Exporter(client).frame(depsgraph, scene, 1, 25)
    c = e.camera
    assert (c["lens"], c["sensor_fit"], c["sensor_height"]) == (35.0, "VERTICAL", 20.0)
    assert (c["shift_x"], c["clip_end"]) == (pytest.approx(0.1), 50.0)
    assert c["clip_start"] == pytest.approx(0.2)
    assert e.resolution == {
        "x": 48,
        "y": 32,
        "percentage": 25,
        "pixel_aspect_x": 2.0,
        "pixel_aspect_y": 1.0,
    }
    cam.type = "ORTHO"
    with pytest.raises(export.ExportError, match="camera 'Camera' is ORTHO"):
        export_now(scene)


@pytest.mark.bpy
def test_unchanged_meshes_are_neither_read_nor_sent_again():
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    mover = add_mesh(scene, "Mover", CUBE_V, CUBE_F)
    for frame, x in ((1, 0.0), (2, 2.0)):
        mover.location.x = x
        mover.keyframe_insert("location", frame=frame)
    bent = add_mesh(scene, "Bent", *GROUND, location=(0, 0, 3))
    lift = bent.modifiers.new("Lift", "DISPLACE")
    lift.strength = 0.5
    lift.keyframe_insert("strength", frame=1)
    lift.strength = 1.5
    lift.keyframe_insert("strength", frame=2)
    with client.LocalSession() as session:
        sent = []
        exporter = export.Exporter(client)
        for frame in (1, 2):
            scene.frame_set(frame)
            e, _ = export_now(scene, exporter)
            missing = session.frame_update(
                frame, e.objects, e.camera, e.lights, e.resolution, e.instances
            )
            for h in missing:
                session.upload_mesh(e.meshes[h].name, e.meshes[h].positions, e.meshes[h].triangles)
            sent.append(sorted(e.meshes[h].name for h in missing))
            if frame == 2:
                # Ground and Mover come from the static cache; Bent's modifier is re-evaluated.
                assert e.extracted == 1
        assert sent == [["Bent", "Ground", "Mover"], ["Bent"]]


@pytest.mark.bpy
def test_non_finite_vertex_names_object_and_frame():
    scene = empty_scene()
    add_mesh(scene, "Fine", *GROUND)
    add_mesh(scene, "Broken", [(0, 0, 0), (1, 0, 0), (0, 1, float("inf"))], [(0, 1, 2)])
    with pytest.raises(export.ExportError, match=r"frame 1: object 'Broken'.*index 2"):
        export_now(scene)


@pytest.fixture
def link(antumbra_bin, short_tmp):
    link = daemon.DaemonLink(binary=str(antumbra_bin), socket_path=str(short_tmp / "d.sock"))
    yield link
    link.stop()


def animated_scene():
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    mover = add_mesh(scene, "Mover", CUBE_V, CUBE_F)
    add_light(scene, "Sun", "SUN", angle=0.0).rotation_euler = (0.4, 0.3, 0.0)
    scene.frame_start, scene.frame_end = 1, 4
    for frame in range(1, 5):
        mover.location.x = frame - 2.5
        mover.keyframe_insert("location", frame=frame)
    scene.frame_set(2)
    return scene


@pytest.mark.bpy
def test_cancelled_job_keeps_complete_frames_only(link, short_tmp):
    scene = animated_scene()
    out = short_tmp / "out"

    def cancel_after_first(job, done):
        job.cancel()

    job = frame_job.RenderJob(
        scene=scene,
        frames=[1, 2, 3, 4],
        options=options.RenderOptions(settings={"spp": 1}),
        link=link,
        out_dir=out,
        on_frame=cancel_after_first,
    ).run()
    assert job.cancelled and job.error is None
    assert [d.frame for d in job.done] == [1]
    assert scene.frame_current == 2, "the scene's frame is restored"
    records = sorted(p.name for p in out.glob("frame_*.stats.json"))
    assert records == ["frame_0001.stats.json"]
    assert len((out / "frames.csv").read_text().strip().splitlines()) == 2
    combined = bpy.data.images["antumbra combined"]
    assert combined["antumbra_frame"] == 1
    assert tuple(combined.size) == (48, 32)


@pytest.mark.bpy
def test_frames_csv_says_which_triangles_it_counts(link, short_tmp):
    """frames.csv's ``triangles_sent`` is what the exporter sent; its ``primary_triangles`` is
    stats.csv's ``triangles`` of the primary pass (the camera rays' tree), which leaves out
    objects hidden from the camera and degenerate triangles; the shadow pass keeps the hidden
    object."""
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    add_mesh(scene, "Cube", CUBE_V, CUBE_F)
    hidden = add_mesh(scene, "Hidden", CUBE_V, CUBE_F, location=(3, 0, 0))
    hidden.visible_camera = False
    sliver = [(0, 2, 1), (1, 2, 1), (2, 2, 1), (0, 3, 1)]
    add_mesh(scene, "Sliver", sliver, [(0, 1, 2), (0, 1, 3)])  # the first is degenerate
    add_light(scene, "Sun", "SUN", angle=0.0)
    out = short_tmp / "out"
    job = frame_job.RenderJob(
        scene=scene,
        frames=[1],
        options=options.RenderOptions(settings={"spp": 1}, heat_maps=False),
        link=link,
        out_dir=out,
    ).run()
    assert job.error is None, job.error
    with open(out / "frames.csv") as f:
        (frame,) = list(csv.DictReader(f))
    with open(out / "stats.csv") as f:
        passes = {row["pass"]: int(row["triangles"]) for row in csv.DictReader(f)}
    assert "triangles" not in frame, "a column named for what it counts"
    assert int(frame["triangles_sent"]) == job.done[0].triangles == 2 + 12 + 12 + 2
    assert int(frame["primary_triangles"]) == passes["primary"] == 2 + 12 + 1
    assert passes["shadow"] == 2 + 12 + 12 + 1


@pytest.mark.bpy
def test_shading_facing_reads_custom_normals_through_the_daemon(link, short_tmp):
    """A ground whose custom normals lean away from a low sun: lit under the default geometric
    convention (as when no normals are sent), shadowed under Cycles' shading convention."""
    scene = empty_scene()
    big = [(x * 200, y * 200, 0) for x, y in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    ground = add_mesh(scene, "Ground", big, [(0, 1, 2, 3)]).data  # fills the view
    if hasattr(ground, "use_auto_smooth"):
        ground.use_auto_smooth = True
    ground.normals_split_custom_set([(0.9, 0.0, 0.3)] * len(ground.loops))
    add_light(scene, "Sun", "SUN", angle=0.0).rotation_euler = (0.0, -1.4, 0.0)

    def sun_mask(settings):
        job = frame_job.RenderJob(
            scene=scene,
            frames=[scene.frame_current],
            options=options.RenderOptions(settings={"spp": 1, **settings}, heat_maps=False),
            link=link,
            out_dir=None,
            load_images=False,
        ).run()
        assert job.error is None, job.error
        return dict(job.done[0].result.planes)["shadow.Sun"]

    geometric, shading = sun_mask({}), sun_mask({"facing": "shading"})
    assert geometric.min() == 1.0, "the sun is 10 degrees above the ground's plane"
    assert shading.max() == 0.0, "and 10 degrees behind its shading normals"


@pytest.mark.bpy
def test_job_reconnects_after_the_daemon_dies(link, short_tmp):
    scene = animated_scene()

    def kill_after_first(job, done):
        if done.frame == 1:
            link.client.process.kill()
            link.client.process.wait()

    job = frame_job.RenderJob(
        scene=scene,
        frames=[1, 2, 3],
        options=options.RenderOptions(settings={"spp": 1}, heat_maps=False),
        link=link,
        out_dir=short_tmp / "out",
        on_frame=kill_after_first,
    ).run()
    assert job.error is None, job.error
    assert [d.frame for d in job.done] == [1, 2, 3]
    assert link.reconnects == 1


@pytest.fixture
def registered(monkeypatch, short_tmp, antumbra_bin):
    addon.register()
    settings = {"binary": str(antumbra_bin), "socket": str(short_tmp / "d.sock"), "auto": True}
    monkeypatch.setattr(
        preferences,
        "get",
        lambda: preferences.Preferences(settings["binary"], settings["socket"], settings["auto"]),
    )
    yield settings
    addon.unregister()


@pytest.mark.bpy
def test_operator_reports_the_broken_object(registered):
    scene = empty_scene()
    add_mesh(scene, "Broken", [(0, 0, 0), (1, 0, 0), (0, 1, float("nan"))], [(0, 1, 2)])
    scene.antumbra.save_files = False
    with pytest.raises(RuntimeError, match=r"frame 1: object 'Broken'"):
        bpy.ops.antumbra.render()
    assert scene.antumbra.status.startswith("failed: frame 1: object 'Broken'")


@pytest.mark.bpy
def test_operator_without_daemon_says_how_to_start_one(registered, short_tmp):
    registered["socket"] = str(short_tmp / "nobody.sock")
    registered["auto"] = False
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    with pytest.raises(RuntimeError, match=r"no antumbra daemon at .*press Start daemon"):
        bpy.ops.antumbra.render()
    # The start button's operator starts one, after which rendering works.
    assert bpy.ops.antumbra.daemon_start() == {"FINISHED"}
    scene.antumbra.save_files = False
    assert bpy.ops.antumbra.render() == {"FINISHED"}
    stats = json.loads(scene.antumbra.last_stats)
    assert stats[0]["pass"] == "primary"
    assert bpy.ops.antumbra.daemon_stop() == {"FINISHED"}
    assert not addon.operators.render.current_link().connected()
    assert Path(registered["socket"]).exists() is False


@pytest.mark.bpy
def test_triangles_equal_blenders_loop_triangles():
    """The numpy split of triangles and quads (and the cached n-gon split) equals Blender's own
    ``loop_triangles``, concave quads included."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add()
    bpy.ops.mesh.primitive_cylinder_add(vertices=12)  # n-gon caps
    bpy.ops.mesh.primitive_uv_sphere_add()  # quads and triangles
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=40, y_subdivisions=40)
    grid = bpy.context.object.data
    co = np.empty(len(grid.vertices) * 3, np.float32)
    grid.vertices.foreach_get("co", co)
    co += np.random.default_rng(1).normal(0, 0.08, co.shape).astype(np.float32)
    grid.vertices.foreach_set("co", co)
    grid.update()
    concave = 0
    for obj in bpy.context.scene.objects:
        mesh = obj.data
        expected = np.empty(len(mesh.loop_triangles) * 3, np.uint32)
        mesh.loop_triangles.foreach_get("vertices", expected)
        got, _ = export._triangles(mesh, None, export._positions(mesh))
        assert np.array_equal(got, expected.reshape(-1, 3)), obj.name
        if obj.name == "Grid":
            # Some quads must have taken the flipped split for this test to mean anything.
            plain = got[1::2, 0] == got[0::2, 0]
            concave = int((~plain).sum())
    assert concave > 0


@pytest.mark.bpy
def test_panel_properties_follow_the_settings_schema(registered):
    """Every setting of the client's schema is a property of the panel's method settings, with
    the schema's default and range, and the panel's values are the settings a render takes."""
    client = client_loader.load()
    schema = client.settings_schema()
    method = bpy.context.scene.antumbra.method
    props = method.bl_rna.properties
    for s in schema:
        assert s["name"] in props, s["name"]
        prop = props[s["name"]]
        if s["type"] == "choice":
            assert [i.identifier for i in prop.enum_items] == [str(c) for c in s["choices"]]
            assert prop.default == str(s["default"]), s["name"]
        elif s["type"] in ("int", "float"):
            default = min(s["default"], method_settings.INT_MAX)  # Blender's ints are 32-bit
            assert prop.default == pytest.approx(default), s["name"]
            assert prop.hard_min == pytest.approx(max(s["min"], -(2**31))), s["name"]
        else:
            assert prop.default == s["default"], s["name"]
    # The panel's untouched values are the defaults; a change reaches the render's settings.
    assert client.render_settings(**method_settings.values(method)) == client.render_settings()
    method.leaf_size = 4
    method.osah_w = 0.5
    got = bpy.context.scene.antumbra.options().settings_kwargs()
    assert (got["leaf_size"], got["osah_w"]) == (4, pytest.approx(0.5))


@pytest.mark.bpy
def test_panel_renders_the_scenes_size_by_default_and_says_so(registered):
    """The panel's resolution scale defaults to 1 (the batch's default: both take it from
    RenderOptions), and the panel shows the size a render makes."""
    scene = empty_scene()
    settings = scene.antumbra
    assert settings.resolution_scale == options.RenderOptions().resolution_scale == 1.0
    scene.render.resolution_x, scene.render.resolution_y = 96, 54
    scene.render.resolution_percentage = 100
    assert addon.ui.panel.size_text(scene) == "Renders 96 x 54 px"
    settings.resolution_scale = 0.5
    assert addon.ui.panel.size_text(scene) == "Renders 48 x 27 px"
    scene.render.resolution_percentage = 50
    assert addon.ui.panel.size_text(scene) == "Renders 24 x 13 px"


def test_panel_in_a_real_window_draws_every_setting(addon_zips, short_tmp):
    """Debian's Blender with a real window (Xvfb): the panel, every group unfolded, draws one
    property per setting of the schema."""
    out = short_tmp / "panel.json"
    done = subprocess.run(
        [
            "xvfb-run",
            "-a",
            "-s",
            "-screen 0 1280x1024x24",
            "blender",
            "--factory-startup",
            "-noaudio",
            "-P",
            str(Path(__file__).parent / "scripts" / "panel_settings.py"),
            "--",
            "--zip",
            str(addon_zips["legacy"]),
            "--out",
            str(out),
        ],
        env=blender_env(short_tmp / "home"),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.exists(), done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads(out.read_text())
    assert report["schema"] and sorted(report["drawn"]) == sorted(report["schema"])


def alpha_material(name, alpha=None, image=None, noise=False):
    """A Principled BSDF whose Alpha is a constant, an image's alpha or a Noise Texture."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    if alpha is not None:
        bsdf.inputs["Alpha"].default_value = alpha
    if image is not None:
        texture = tree.nodes.new("ShaderNodeTexImage")
        texture.image = image
        texture.interpolation = "Closest"
        tree.links.new(texture.outputs["Alpha"], bsdf.inputs["Alpha"])
    if noise:
        texture = tree.nodes.new("ShaderNodeTexNoise")
        tree.links.new(texture.outputs["Fac"], bsdf.inputs["Alpha"])
    return material


def card(scene, name, location, material):
    """A 2 x 2 quad facing up with UVs (0, 0)-(1, 1) and MATERIAL."""
    quad = ([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [(0, 1, 2, 3)])
    obj = add_mesh(scene, name, *quad, location=location)
    layer = obj.data.uv_layers.new(name="UVMap")
    layer.data.foreach_set("uv", [0, 0, 1, 0, 1, 1, 0, 1])
    obj.data.materials.append(material)
    return obj


@pytest.mark.bpy
def test_alpha_materials_travel_with_their_meshes_and_warnings_are_said_once():
    scene = empty_scene()
    add_mesh(scene, "Ground", *GROUND)
    add_light(scene, "Sun", "SUN", angle=0.0)
    leaf = bpy.data.images.new("Leaf", 2, 1, alpha=True)
    leaf.pixels.foreach_set([1, 1, 1, 1, 1, 1, 1, 0])  # opaque left, transparent right
    card(scene, "Glass", (-3, 0, 1), alpha_material("Glass", alpha=0.5))
    card(scene, "Card", (3, 0, 1), alpha_material("Leaf", image=leaf))
    card(scene, "Noisy", (0, 3, 1), alpha_material("Noisy", noise=True))
    exporter = export.Exporter(client)
    e, _ = export_now(scene, exporter)
    objects = by_name(e)
    # Opaque objects travel as before; the unsupported graph is opaque, with a warning once.
    assert "materials" not in objects["Ground"] and "materials" not in objects["Noisy"]
    assert len(e.warnings) == 1 and "material 'Noisy'" in e.warnings[0], e.warnings
    assert "ShaderNodeTexNoise" in e.warnings[0] and "exported opaque" in e.warnings[0]
    names = [m["name"] for m in e.alpha.materials]
    assert sorted(names) == ["Glass", "Leaf"]
    glass, leaf_material = (e.alpha.materials[names.index(n)] for n in ("Glass", "Leaf"))
    assert glass == {"name": "Glass", "kind": "constant", "alpha": 0.5}
    assert leaf_material["kind"] == "texture" and leaf_material["interpolation"] == "Closest"
    assert objects["Glass"]["materials"] == [names.index("Glass")]
    assert objects["Card"]["materials"] == [names.index("Leaf")]
    texels = e.alpha.images[leaf_material["image"]]
    assert texels.shape == (1, 2) and texels.tolist() == [[1.0, 0.0]]
    card_mesh = e.meshes[objects["Card"]["mesh_hash"]]
    assert card_mesh.material_slots.tolist() == [0, 0]
    assert list(card_mesh.uv_maps) == [leaf_material["uv_map"]]
    assert e.meshes[objects["Noisy"]["mesh_hash"]].material_slots is None

    e2, _ = export_now(scene, exporter)
    assert e2.warnings == [] and e2.alpha.warnings == e.alpha.warnings
    assert e2.extracted == 0  # the static meshes' slots and UVs came from the cache
    assert by_name(e2)["Card"]["mesh_hash"] == objects["Card"]["mesh_hash"]

    with client.LocalSession() as session:
        export.send(session, e)
        lit = session.render(e.frame, spp=1, passes=("masks",), alpha_clip=0.6).masks["Sun"]
        whole = session.render(e.frame, spp=1, passes=("masks",), alpha=False).masks["Sun"]
    # The glass casts 0.5 (the camera sees the ground through it); alpha off casts black.
    assert np.count_nonzero(lit == 0.5) > 20
    assert np.count_nonzero(whole == 0.5) == 0
    assert np.count_nonzero(whole == 0.0) > np.count_nonzero(lit == 0.0)
