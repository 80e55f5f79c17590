from blinkcan.cli.main import main

main()
