"""The scenes shipped with hertzmap: study files installed as package data (``hertzmap.scenes``),
listed by ``hertzmap scenes`` and run by name (``hertzmap run default``)."""
