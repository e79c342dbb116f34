"""Run inside freecadcmd by tests/test_addon_manager.py: FreeCAD's own Addon Manager (its
Mod/AddonManager modules) installs HullProd, or reads a package.xml; the outcome is written as
JSON to $HULLPROD_AM_RESULT.

Environment: HULLPROD_AM_TASK "install" (HULLPROD_AM_SOURCE: a local folder holding the
workbench), "metadata" or "freecad-metadata" (HULLPROD_AM_SOURCE: a package.xml)."""
import contextlib
import io
import json
import os
import traceback

import FreeCAD


def _version(v):
    """An Addon Manager Version as [major, minor, patch, suffix], or None."""
    return None if v is None else list(v.version_as_list)


def _install(source, result):
    """AddonInstaller(Addon("HullProd", source, branch "main")).run(), as the Addon Manager does."""
    import addonmanager_installer
    from Addon import Addon, MissingDependencies
    result["imported"] = True
    installer_class = addonmanager_installer.AddonInstaller
    result["installer_module"] = addonmanager_installer.__file__
    # The Addon Manager's own allow-list of Python packages: with one loaded, the installer does
    # not fetch the remote list (no network here).
    installer_class._load_local_allowed_packages_list()
    addon = Addon("HullProd", source, Addon.Status.NOT_INSTALLED, "main")
    installer = installer_class(addon)
    signals = []
    installer.success.connect(lambda a: signals.append("success"))
    installer.failure.connect(lambda a, message: signals.append("failure: %s" % message))
    installer.finished.connect(lambda: signals.append("finished"))
    result["returned"] = installer.run()
    result["signals"] = signals
    result["installation_path"] = os.path.join(installer.installation_path, addon.name)
    result["status"] = addon.status().name
    result["installed_version"] = _version(addon.installed_version)
    result["workbench"] = addon.get_workbench_name() if addon.metadata is not None else None
    # The dependency check the Addon Manager's GUI makes before installing (AddonInstallerGUI.run),
    # on the metadata the installer loaded: Python packages it finds not importable here.
    if hasattr(MissingDependencies, "import_from_addon"):  # 1.1
        missing = MissingDependencies()
        missing.import_from_addon(addon, [])
    else:  # 1.0
        missing = MissingDependencies(addon, [])
    result["python_requires"] = sorted(addon.python_requires)
    result["python_missing"] = sorted(missing.python_requires + missing.python_optional)
    result["python_allowed"] = sorted(installer_class.allowed_packages)


def _metadata(path, result):
    """MetadataReader.from_file(path) and Addon.load_metadata_file(path), printing captured."""
    import addonmanager_metadata
    from Addon import Addon
    result["imported"] = True
    result["metadata_module"] = addonmanager_metadata.__file__
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed):
        md = addonmanager_metadata.MetadataReader.from_file(path)
        addon = Addon("HullProd", "", Addon.Status.NOT_INSTALLED, "main")
        addon.load_metadata_file(path)
    result["printed"] = printed.getvalue()
    result["name"] = md.name
    result["version"] = _version(md.version)
    result["freecadmin"] = _version(md.freecadmin)
    result["licenses"] = [lic.name for lic in md.license]
    result["repository"] = [[u.location, u.branch] for u in md.url
                            if u.type == addonmanager_metadata.UrlType.repository]
    result["python_depends"] = sorted(d.package for d in md.depend
                                      if d.dependency_type == addonmanager_metadata.DependencyType.python)
    result["workbenches"] = [{"name": wb.name, "classname": wb.classname, "subdirectory": wb.subdirectory,
                              "freecadmin": _version(wb.freecadmin)}
                             for wb in md.content.get("workbench", [])]
    result["version_ok_here"] = Addon.version_is_ok(md)
    result["addon_workbench"] = addon.get_workbench_name()
    result["addon_python_requires"] = sorted(addon.python_requires)


def _freecad_metadata(path, result):
    """FreeCAD.Metadata(path): FreeCAD's own reader, which its start-up uses on Mod folders'
    package.xml (0.20 and later) and the 0.20 Addon Manager uses as its parser."""
    result["imported"] = True
    md = FreeCAD.Metadata(path)
    result["name"] = md.Name
    result["version"] = md.Version
    result["freecadmin"] = md.FreeCADMin
    result["licenses"] = [lic["name"] for lic in md.License]
    result["depends"] = sorted(d["package"] for d in md.Depend)
    result["workbenches"] = [{"name": wb.Name, "classname": wb.Classname, "subdirectory": wb.Subdirectory,
                              "freecadmin": wb.FreeCADMin} for wb in md.Content.get("workbench", [])]
    result["supports_here"] = md.supportsCurrentFreeCAD()


def main():
    result = {"freecad": list(FreeCAD.Version()[:3]), "user_app_data": FreeCAD.getUserAppDataDir()}
    task, source = os.environ["HULLPROD_AM_TASK"], os.environ["HULLPROD_AM_SOURCE"]
    try:
        {"install": _install, "metadata": _metadata, "freecad-metadata": _freecad_metadata}[task](source, result)
    except ImportError as e:
        if result.get("imported"):  # raised once the Addon Manager was imported: an error
            result["exception"] = traceback.format_exc()
        else:
            result["import_error"] = "%s: %s" % (type(e).__name__, e)
    except Exception:  # reported to the test, which fails with it
        result["exception"] = traceback.format_exc()
    with open(os.environ["HULLPROD_AM_RESULT"], "w", encoding="utf-8") as f:
        json.dump(result, f, indent=1)


main()
