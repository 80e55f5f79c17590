from blinkcan.cli.entry import main

main()
