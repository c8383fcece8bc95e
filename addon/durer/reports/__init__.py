"""Report generators: the measured pages in docs/ (`python -m durer accuracy`, `numerics`, `gallery`),
the machine description they print and the scenes they and bench/ measure.

The library (`durer`, `durer.blender`, `durer.course`'s reader and raytracer) never imports this
package: it needs the report extras (matplotlib, mpmath) and exists only to measure the library.
"""
