"""Front panel of the emulated devices in the browser (optional extra ``[web]``)."""
