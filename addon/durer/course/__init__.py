"""MIT 6.837 (Fall 2004) ray casting: the scene-file reader (`scene_file`), the course's
`raytracer` command (`python -m durer raytracer`) and the gallery of the course's official command
lines (`python -m durer gallery`). See docs/6837.md."""
