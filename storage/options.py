"""The ``--storage-option KEY=VALUE`` command-line option: s3fs options of ``s3://`` stores, shared by every
``svgen`` and ``svtrain`` command that takes a store."""
from __future__ import annotations

import click


def storage_option(f):
    """--storage-option KEY=VALUE (repeatable): s3fs options of s3:// stores (endpoint_url, key, secret, ...).

    Applied when parsed (into this process's environment, which local dask workers inherit) and never recorded.
    """
    def apply(ctx, param, value):
        if value:
            from .objstore import set_storage_options

            set_storage_options(value)
        return value

    return click.option("--storage-option", "storage_options", multiple=True, metavar="KEY=VALUE",
                        expose_value=False, callback=apply,
                        help="An s3fs option for s3:// stores (repeatable; dotted keys nest, values are YAML), "
                             "e.g. endpoint_url=http://127.0.0.1:9000. Credentials: prefer AWS_* variables; "
                             "options are never recorded.")(f)
