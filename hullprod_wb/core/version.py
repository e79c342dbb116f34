"""The package's version (hullprod_wb.__version__; package.xml's <version> is the same)."""
__version__ = "0.1.0"
