from whiskercal.cli import main

main()
