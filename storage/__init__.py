"""storage: the zarr v3 stores svgen writes and reads, on a local disk or on object storage (``s3://``).

What this package promises every stage, reader and command (and what its tests hold it to):

* **Atomic creation.** A store never looks complete before it is. Locally it is built under ``<out>.partial``
  (itself created whole under ``.partial.creating``) and renamed into place; on object storage it is written in
  place and committed by one write of ``complete: true``. Readers refuse anything else in one line.
* **Resume.** A killed run leaves a partial store whose config hash and per-chunk markers let the rerun write
  only the missing chunks, with the same bytes; a different configuration is refused, never mixed in.
* **One writer.** A second run on the same output is refused (``flock`` locally, a conditional-put lock with a
  heartbeat on ``s3://``); an output inside one of its inputs is refused too.
* **Integrity.** Every finished store carries a manifest (size and SHA-256 of every chunk file): every open
  checks that each chunk is there with its size, every read checks zarr's CRC32C, and ``verify_store`` re-hashes
  every chunk on request.

Modules (one job each):

* :mod:`storage.store`: the door: ``open_writer``, ``write_chunk``, ``open_store``, ``verify_store``,
  ``card_text``/``write_card``; picks the backend by the path;
* :mod:`storage.local`: the store format (arrays, shards, manifest, markers) and the local-filesystem backend;
* :mod:`storage.store_object`: the commit protocol on object storage;
* :mod:`storage.objstore`: object-store URLs, s3fs storage options and error translation;
* :mod:`storage.options`: the ``--storage-option`` command-line option (shared by ``svgen`` and ``svtrain``);
* :mod:`storage.svbrdf_store`: the schema and reader of the variants, blends and stress stores;
* :mod:`storage.renders_store`: the schema and reader of the renders store (what the training loader reads);
* :mod:`storage.views`: a renders store's view (:class:`~storage.views.ViewParams`) and the drjit transform that
  gives its aligned maps, shared by the renderer and the reader;
* :mod:`storage.srgb8`: the 8-bit sRGB codes of rendered images (numpy, and drjit for the renderer);
* :mod:`storage.card`: the dataset card (``README.md``) written into every store;
* :mod:`storage.dataset`: a store as an analysis-ready xarray dataset (labelled coordinates, float32 maps,
  shard-sized chunks, netCDF-writable attributes);
* :mod:`storage.bounds`: up-front resource checks (memory, disk) of a store about to be written.

Layering: ``storage`` imports ``svcore`` and ``materials`` (map names and encodings; mitsuba and drjit through
:mod:`svcore.mi_env`), never ``pipeline`` or ``train``, with no exception (tests/test_layout.py holds it).
"""
