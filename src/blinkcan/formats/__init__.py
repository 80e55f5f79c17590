"""Files for other tools, written from the device descriptions: EDS (python-canopen), DBC, pcap."""
